//! A sequential test for small persistent faults: a fault that moves a residual by a fraction
//! of its threshold never crosses it, but moves its running sum steadily.

/// A two-sided CUSUM (Page's test) on a residual whitened by its noise's deviation: the sums
/// `g⁺ ← max(0, g⁺ + r/σ − k)` and `g⁻ ← max(0, g⁻ − r/σ − k)`, in alarm while either is above
/// `h`. A mean shift of `δ σ` (`δ > k`) raises it after about `h / (δ − k)` samples; on noise
/// alone the sums drift down by `k` a sample and rarely reach `h`. `k` is half the shift it is
/// tuned for, `h` sets the time between false alarms (`bgc residuals --cusum` calibrates both).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cusum {
    sigma: f64,
    drift: f64,
    level: f64,
    up: f64,
    down: f64,
}

impl Cusum {
    /// A test on residuals of noise deviation `sigma`, with drift `drift` (in deviations) and
    /// level `level`, its sums at zero.
    #[must_use]
    pub fn new(sigma: f64, drift: f64, level: f64) -> Cusum {
        Cusum {
            sigma,
            drift,
            level,
            up: 0.0,
            down: 0.0,
        }
    }

    /// Takes one residual sample and returns whether the alarm is on; a sample that is not a
    /// number (a singular relation) leaves the sums where they were.
    #[inline]
    pub fn update(&mut self, residual: f64) -> bool {
        if residual.is_finite() {
            let z = residual / self.sigma;
            self.up = (self.up + z - self.drift).max(0.0);
            self.down = (self.down - z - self.drift).max(0.0);
        }
        self.alarm()
    }

    /// The larger of the two sums.
    #[must_use]
    pub fn statistic(&self) -> f64 {
        self.up.max(self.down)
    }

    /// Whether either sum is above the level.
    #[must_use]
    pub fn alarm(&self) -> bool {
        self.statistic() > self.level
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shift of half the threshold never crosses it; the CUSUM sees it after
    /// `h / (δ − k)` samples, and on zero mean its sums stay at 0.
    #[test]
    fn a_small_shift_is_seen_after_level_over_the_excess_samples() {
        let mut test = Cusum::new(2.0, 0.5, 10.0);
        for _ in 0..1000 {
            assert!(!test.update(0.9));
        }
        assert_eq!(test.statistic(), 0.0);
        // 2σ below: 1.5 a sample over the drift, on the lower sum.
        let mut at = None;
        for k in 0..100 {
            if test.update(-4.0) {
                at = Some(k);
                break;
            }
        }
        assert_eq!(at, Some(6));
        assert!(test.update(f64::NAN), "a NaN keeps the sums");
        for _ in 0..100 {
            test.update(0.0);
        }
        assert!(!test.alarm(), "the sums drain once the shift is gone");
    }
}
