//! Integrals of sampled signals from the start of the record.

use crate::differentiate::Differentiator;

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

    /// [`Trapezoid::push`] of each sample `(t[i], x[i])` in turn, the integral after each
    /// written to `out[i]`: the same sums, with the rule's state held in registers over
    /// the slice rather than stored back after every sample.
    pub fn push_slice(&mut self, t: &[f64], x: &[f64], out: &mut [f64]) {
        let (mut last, mut sum) = (self.last, self.sum);
        for ((&t, &x), out) in t.iter().zip(x).zip(out) {
            if let Some((t0, x0)) = last {
                sum += 0.5 * (t - t0) * (x + x0);
            }
            last = Some((t, x));
            *out = sum;
        }
        (self.last, self.sum) = (last, sum);
    }

    /// An integral that continues from `sum` at time `t`, where the signal is `x`.
    #[must_use]
    pub fn resume(t: f64, x: f64, sum: f64) -> Trapezoid {
        Trapezoid {
            last: Some((t, x)),
            sum,
        }
    }

    /// The integral so far.
    #[must_use]
    pub fn value(&self) -> f64 {
        self.sum
    }
}

/// A signal's integral from the start of the record, passed through the same estimator as
/// the signal so that it refers to the same instant as the signal's derivatives.
///
/// Until the estimator's window is full, the raw samples' trapezoidal integral is fed to the
/// estimator. From its first estimate on, the integral continues as the trapezoidal integral
/// of the signal's own estimate: an estimator that is linear and time-invariant commutes with
/// the rule's increments, so for a fixed-window fit such as [`SavitzkyGolay`](crate::SavitzkyGolay)
/// this is the estimate of the integral up to rounding, without a second estimator per
/// integral. For a recursive filter the two differ by a start-up transient that decays at
/// the filter's rate.
#[derive(Clone, Debug)]
pub struct EstimatedIntegral<D> {
    phase: Phase<D>,
}

#[derive(Clone, Debug)]
enum Phase<D> {
    /// The raw integral goes through the estimator until it gives its first estimate.
    Warming { raw: Trapezoid, estimator: D },
    /// The integral of the signal's estimate, from the estimator's first estimate.
    Running(Trapezoid),
}

impl<D: Differentiator> EstimatedIntegral<D> {
    /// An integral that starts at zero with the first sample, estimated by `estimator`
    /// (which should be the signal's estimator, or one like it, built for order 0).
    #[must_use]
    pub fn new(estimator: D) -> EstimatedIntegral<D> {
        EstimatedIntegral {
            phase: Phase::Warming {
                raw: Trapezoid::new(),
                estimator,
            },
        }
    }

    /// Takes the raw sample `x` at time `t` (uniform steps) and the signal's own estimate at
    /// this sample, if its estimator gave one; returns the integral's estimate at the same
    /// instant once both exist.
    pub fn push(&mut self, t: f64, x: f64, estimate: Option<f64>) -> Option<f64> {
        match &mut self.phase {
            Phase::Running(integral) => estimate.map(|y| integral.push(t, y)),
            Phase::Warming { raw, estimator } => {
                let value = raw.push(t, x);
                let first = estimator.push(value).and_then(|d| d.first().copied())?;
                // The estimates lag `t` by the estimator's delay; with uniform steps the
                // rule's increments are the same whichever instant they are labelled with.
                self.phase = Phase::Running(Trapezoid::resume(t, estimate?, first));
                Some(first)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SavitzkyGolay;

    /// ∫₀¹ t dt = 1/2 exactly (linear), ∫₀^π sin = 2 to h²-accuracy.
    #[test]
    fn the_trapezoid_rule_is_exact_on_lines_and_second_order_on_curves() {
        let mut line = Trapezoid::new();
        let mut sine = Trapezoid::new();
        let n = 1000;
        let h = core::f64::consts::PI / n as f64;
        let mut last = 0.0;
        for k in 0..=n {
            let t = k as f64 * h;
            last = line.push(t / core::f64::consts::PI, t / core::f64::consts::PI);
            sine.push(t, t.sin());
        }
        assert!((last - 0.5).abs() < 1e-12);
        let bound = h * h * core::f64::consts::PI / 12.0;
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

    /// After the window fills, the integral of the estimate is the estimate of the integral:
    /// the same numbers, up to rounding, as a second fit over the raw integral.
    #[test]
    fn a_slice_is_its_samples_pushed_in_turn() {
        let t: Vec<f64> = (0..50).map(|k| f64::from(k) * 0.1).collect();
        let x: Vec<f64> = t.iter().map(|t| (3.0 * t).cos()).collect();
        let mut one = Trapezoid::new();
        let single: Vec<u64> = (t.iter().zip(&x))
            .map(|(&t, &x)| one.push(t, x).to_bits())
            .collect();
        let mut many = Trapezoid::new();
        let mut out = vec![0.0; t.len()];
        for (start, end) in [(0, 1), (1, 17), (17, 50)] {
            many.push_slice(&t[start..end], &x[start..end], &mut out[start..end]);
        }
        assert_eq!(out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), single);
        assert_eq!(many, one);
    }

    #[test]
    fn the_integral_of_the_estimate_is_the_estimate_of_the_integral() {
        let h = 1e-3;
        let fit = || SavitzkyGolay::new(0, 3, 11, h, true).expect("valid");
        let (mut signal, mut both, mut raw, mut reference) = (
            fit(),
            EstimatedIntegral::new(fit()),
            Trapezoid::new(),
            fit(),
        );
        let mut compared = 0;
        for k in 0..20_000 {
            let t = k as f64 * h;
            let x = (3.0 * t).sin() + 0.2 * (40.0 * t).cos() + 1.0;
            let estimate = signal.push(x).map(|d| d[0]);
            let got = both.push(t, x, estimate);
            let want = reference.push(raw.push(t, x)).map(|d| d[0]);
            assert_eq!(got.is_some(), want.is_some(), "sample {k}");
            if let (Some(g), Some(w)) = (got, want) {
                assert!((g - w).abs() <= 1e-12 * (1.0 + w.abs()), "{k}: {g} {w}");
                compared += 1;
            }
        }
        assert_eq!(compared, 20_000 - 10);
    }
}
