//! Integrals of sampled signals from the start of the record.

/// The trapezoidal rule over irregular or regular samples: exact for signals linear between
/// samples, error `h² T max|x''| / 12` over a record of length `T` at step `h`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Trapezoid {
    last: Option<(f64, f64)>,
    sum: f64,
}

impl Trapezoid {
    /// An integral that starts at zero with the first sample.
    #[must_use]
    pub fn new() -> Trapezoid {
        Trapezoid::default()
    }

    /// Adds the sample `x` at time `t` and returns the integral from the first sample to `t`.
    pub fn push(&mut self, t: f64, x: f64) -> f64 {
        if let Some((t0, x0)) = self.last {
            self.sum += 0.5 * (t - t0) * (x + x0);
        }
        self.last = Some((t, x));
        self.sum
    }

    /// The integral so far.
    #[must_use]
    pub fn value(&self) -> f64 {
        self.sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫₀¹ t dt = 1/2 exactly (linear), ∫₀^π sin = 2 to h²-accuracy.
    #[test]
    fn the_trapezoid_rule_is_exact_on_lines_and_second_order_on_curves() {
        let mut line = Trapezoid::new();
        let mut sine = Trapezoid::new();
        let n = 1000;
        let h = std::f64::consts::PI / n as f64;
        let mut last = 0.0;
        for k in 0..=n {
            let t = k as f64 * h;
            last = line.push(t / std::f64::consts::PI, t / std::f64::consts::PI);
            sine.push(t, t.sin());
        }
        assert!((last - 0.5).abs() < 1e-12);
        let bound = h * h * std::f64::consts::PI / 12.0;
        assert!(
            (sine.value() - 2.0).abs() <= bound * 1.01,
            "{}",
            sine.value()
        );
        assert!(
            (sine.value() - 2.0).abs() > bound * 0.5,
            "the error is second order"
        );
    }
}
