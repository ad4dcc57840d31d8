//! The noise of a residual integrated from the start: white noise plus a random walk, told
//! from a drift (a model's error integrated) on a healthy record, and the level its normalised
//! walk crosses with a stated probability.

/// The noise of a residual integrated from the start, as white noise plus a random walk: its
/// mean square at `k` samples from the start is `floor + rate * k`. The white part is what the
/// estimates of `F` carry, the walk what integrating `A`'s noise adds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Walk {
    /// The white part's mean square.
    pub floor: f64,
    /// The walk's mean square growth per sample.
    pub rate: f64,
    /// A steady drift allowed for, per sample: the model's error integrated, which a walk
    /// fitted on a short record cannot tell from its noise but which, over a record many times
    /// as long, outgrows it (on the bench drawn 3 % off, ARR2 drifted by 2e-6 per second, past
    /// a constant threshold after 1,350 s of a 3,000-s record calibrated on 200 s).
    pub drift: f64,
}

impl Walk {
    /// Stretches of the longer lag a healthy record must hold: the lags are a hundredth and a
    /// twenty-fifth of the record, where a walk and a drift differ, unless the estimators'
    /// correlation makes them longer.
    const STRETCHES: usize = 25;
    /// How much more than a random walk's (the ratio of the lags) the mean square change may
    /// grow between the two lags: a steady drift's grows as the ratio squared.
    const SLACK: f64 = 1.5;

    /// The walk a residual integrated from the start follows on a healthy record, estimated
    /// from its mean square change over two lags, both past the estimators' correlation
    /// (`window` samples). `None` where the record is too short to tell, or where the residual
    /// drifts (a model error integrated): a threshold from one record would then not hold on
    /// another.
    pub fn fit(r: &[f64], window: usize) -> Option<Walk> {
        // A start-up left out is not a number: the walk is read after it.
        let first = r.iter().position(|v| v.is_finite()).unwrap_or(r.len());
        let r = &r[first..];
        if !Self::can_tell(r.len(), window) {
            return None;
        }
        let short = (2 * window.max(1)).max(r.len() / (4 * Self::STRETCHES));
        let long = 4 * short;
        let (a, b) = (mean_square_change(r, short), mean_square_change(r, long));
        let lags = (long / short) as f64;
        // A NaN (a residual that is not a number somewhere) is no walk either.
        let walks = b.partial_cmp(&(Self::SLACK * lags * a));
        if !matches!(
            walks,
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            return None;
        }
        let rate = ((b - a) / (long - short) as f64).max(0.0);
        let floor = (a - rate * short as f64).max(0.0);
        (floor + rate > 0.0).then_some(Walk {
            floor,
            rate,
            drift: 0.0,
        })
    }

    /// Whether a record of `len` samples, read by estimators over `window` samples, is long
    /// enough to tell a walk from a drift: [`Walk::STRETCHES`] stretches of the longer lag,
    /// itself four times the shorter, which is past the estimators' correlation.
    pub fn can_tell(len: usize, window: usize) -> bool {
        let short = (2 * window.max(1)).max(len / (4 * Self::STRETCHES));
        len >= Self::STRETCHES * 4 * short
    }

    /// The probability a healthy residual may cross its threshold anywhere on a record of
    /// [`Walk::HORIZON`] times the healthy record's length, where the user states none.
    pub const CROSSING: f64 = 1e-3;
    /// The length of the records the crossing probability is stated for, in healthy
    /// records.
    pub const HORIZON: f64 = 1.0;

    /// The threshold, in deviations, that a residual following this walk crosses anywhere
    /// on a record of [`Walk::HORIZON`] times `length` samples with probability `p`: the
    /// maximum over one record is an extreme value that says little
    /// of the next (on the bench drawn 3 % off, the maxima over other seeds' records came
    /// to 1.1 to 1.34 times the calibration record's). The normalised walk `W(k)/√k` is, in
    /// `ln k`, a stationary Ornstein–Uhlenbeck process of correlation `e^{−|Δ|/2}`, whose
    /// maximum over a span `S` of `ln k` exceeds `c` on either side with probability about
    /// `S c φ(c)` (Pickands). The walk's rate is itself estimated from 25 stretches, with a
    /// relative error of about `√(2/25)`: the deviation is taken two such errors above it.
    pub fn crossing_level(&self, length: usize, p: f64) -> f64 {
        let first = if self.rate > 0.0 {
            (self.floor / self.rate).max(1.0)
        } else {
            return 0.0;
        };
        let last = (Self::HORIZON * length as f64).max(first * std::f64::consts::E);
        let span = (last / first).ln();
        let density = |c: f64| (-0.5 * c * c).exp() / (2.0 * std::f64::consts::PI).sqrt();
        // S c φ(c) decreases past c = 1: bisection for the level.
        let (mut lo, mut hi) = (1.0f64, 40.0f64);
        for _ in 0..100 {
            let c = 0.5 * (lo + hi);
            if span * c * density(c) > p {
                lo = c;
            } else {
                hi = c;
            }
        }
        let uncertain = 1.0 + 2.0 * (2.0 / Self::STRETCHES as f64).sqrt();
        hi * uncertain.sqrt()
    }

    /// The noise's deviation at `k` samples from the start.
    pub fn deviation(&self, k: usize) -> f64 {
        (self.floor + self.rate * k as f64)
            .sqrt()
            .max(f64::MIN_POSITIVE)
    }

    /// The threshold at `k` samples from the start for a level in deviations: the level
    /// times the deviation there, plus the drift allowed for over `k` samples.
    pub fn threshold(&self, level: f64, k: usize) -> f64 {
        level * self.deviation(k) + self.drift * k as f64
    }

    /// The drift of `r` (a residual integrated from the start, over a healthy record) to
    /// allow for: its least-squares slope per sample, in magnitude, and three times `error`
    /// (the slope's standard error under the record's noise) above it, over the whole record
    /// and over its second half (a start-up's transient bends the first half), whichever is
    /// larger, times `1 + margin`. On the bench drawn 3 % off, the drift of ARR2 (1.5e-6 per
    /// second) is within the noise of a 200-s record's slope, and outgrows a constant threshold
    /// after 1,350 s: it is bounded by what the record can tell, not by what it shows.
    pub fn drift_of(r: &[f64], error: f64, margin: f64) -> f64 {
        let half = r.len() / 2;
        // A slope over half the samples has 2^1.5 times the standard error.
        let whole = slope(r, 0) + 3.0 * error;
        let second = slope(&r[half..], half) + 3.0 * 2f64.powf(1.5) * error;
        whole.max(second) * (1.0 + margin)
    }
}

/// The magnitude of the least-squares slope per sample of the finite values of `r` (whose
/// first sample is the `offset`-th), 0 where there are fewer than 3.
pub(crate) fn slope(r: &[f64], offset: usize) -> f64 {
    let points: Vec<(f64, f64)> = (r.iter().enumerate())
        .filter(|(_, v)| v.is_finite())
        .map(|(k, &v)| ((k + offset) as f64, v))
        .collect();
    let n = points.len() as f64;
    if n < 3.0 {
        return 0.0;
    }
    let (mk, mv) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (k, v)| (a + k / n, b + v / n));
    let (sxy, sxx) = (points.iter()).fold((0.0, 0.0), |(xy, xx), (k, v)| {
        (xy + (k - mk) * (v - mv), xx + (k - mk) * (k - mk))
    });
    if sxx > 0.0 {
        (sxy / sxx).abs()
    } else {
        0.0
    }
}

/// The mean of `(r[k + lag] - r[k])²` over a series.
fn mean_square_change(r: &[f64], lag: usize) -> f64 {
    let n = r.len().saturating_sub(lag);
    let sum: f64 = r
        .iter()
        .zip(&r[lag.min(r.len())..])
        .map(|(a, b)| (b - a) * (b - a))
        .sum();
    sum / n.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drift is allowed for at its slope, and where the noise hides it, at three standard
    /// errors of the slope above what the record shows; the second half's slope counts where
    /// a start-up bends the first.
    #[test]
    fn the_drift_allowed_is_the_slope_and_what_the_noise_may_hide() {
        let ramp: Vec<f64> = (0..1000).map(|k| 2e-3 * k as f64).collect();
        assert!((Walk::drift_of(&ramp, 0.0, 0.0) - 2e-3).abs() < 1e-12);
        assert!((Walk::drift_of(&ramp, 0.0, 0.2) - 2.4e-3).abs() < 1e-12);
        let flat = vec![1.0; 1000];
        let hidden = Walk::drift_of(&flat, 1e-4, 0.0);
        assert!(
            (hidden - 3.0 * 2f64.powf(1.5) * 1e-4).abs() < 1e-12,
            "{hidden}"
        );
        // Flat for half the record, then a ramp: the second half's slope.
        let bent: Vec<f64> = (0..1000)
            .map(|k| if k < 500 { 0.0 } else { (k - 500) as f64 })
            .collect();
        assert!((Walk::drift_of(&bent, 0.0, 0.0) - 1.0).abs() < 1e-9);
    }

    /// A reproducible standard normal sequence (Box–Muller over a linear congruential
    /// generator): the tests must not depend on a crate's random numbers.
    fn normal(n: usize, seed: u64) -> Vec<f64> {
        let mut state = seed;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u, v) = (uniform(), uniform());
                (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
            })
            .collect()
    }

    #[test]
    fn a_walk_is_told_from_white_noise_and_a_drift_is_refused() {
        let n = 200_000;
        let white = normal(n, 1);
        let steps = normal(n, 2);
        let walk: Vec<f64> = (steps.iter())
            .scan(0.0, |s, x| {
                *s += 0.01 * x;
                Some(*s)
            })
            .zip(&white)
            .map(|(w, x)| w + x)
            .collect();
        let fitted = Walk::fit(&walk, 10).expect("a walk");
        // floor = 2 σ² = 2, rate = 1e-4 per sample.
        assert!((fitted.floor - 2.0).abs() < 0.2, "{fitted:?}");
        assert!((fitted.rate / 1e-4 - 1.0).abs() < 0.3, "{fitted:?}");
        let pure = Walk::fit(&white, 10).expect("white noise");
        assert!(
            pure.rate < 1e-5 && (pure.floor - 2.0).abs() < 0.2,
            "{pure:?}"
        );
        let drift: Vec<f64> = (0..n)
            .map(|k| 1e-3 * k as f64)
            .zip(&white)
            .map(|(d, x)| d + x)
            .collect();
        assert_eq!(Walk::fit(&drift, 10), None);
        // Lags past a 201-sample estimator's correlation leave 3,000 samples too few stretches.
        assert!(Walk::fit(&walk[..3000], 10).is_some());
        assert_eq!(Walk::fit(&walk[..3000], 201), None, "too short to tell");
    }
}
