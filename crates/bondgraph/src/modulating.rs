//! Derivatives by modulating functions: integration by parts against a smooth window.

use crate::prelude::*;

use crate::differentiate::{Differentiator, EstimatorError};
use crate::fir::Fir;

/// Estimates a signal's derivatives as `∫ φ(s) x⁽ᵏ⁾ ds = (−1)ᵏ ∫ φ⁽ᵏ⁾(s) x ds` over the last
/// `window` samples, with `φ(s) = sᵃ (T − s)ᵃ` (`T` the window's span) normalised to unit
/// area: integration by parts moves every derivative onto `φ`, which vanishes with its first
/// `a − 1` derivatives at both ends, so no sample is differentiated.
///
/// Why it suits ARRs: the estimate of order `k` is the `k`-th derivative of one smoothed
/// signal, `x` weighted by `φ`, for every `k` alike (a Savitzky–Golay fit's are not: each
/// order has a polynomial error of its own). An ARR that is linear in the signals and their
/// derivatives with constant coefficients is then exactly zero on the estimates of a healthy
/// plant's signals, up to the quadrature's error, at any window; a longer window only
/// averages more noise away and smears a fault over its span. An ARR with signal-dependent
/// coefficients holds to the extent the coefficients change slowly over the window.
///
/// The estimates refer to the window's centre (`φ` is symmetric): delay `(window − 1)/2`
/// samples. White noise of deviation `σ` gives about `σ (w h)⁻ᵏ / √w` on the derivative of
/// order `k`. Take `a` one above the highest order read, so that `φ⁽ᵏ⁾` is smooth and rolls
/// high frequencies off. The samples are taken as joined by straight lines, and the integrals
/// are exact for that: every order is the exact derivative of the same average of the joined
/// samples, whose error against the signal (about `h² |x''| / 8`) the window smooths.
#[derive(Clone, Debug)]
pub struct ModulatingFunction {
    /// `weights[k·window + j]`: the k-th derivative's weight of the j-th oldest sample.
    fir: Fir,
    delay: f64,
}

impl ModulatingFunction {
    /// Derivatives up to `order` against `φ(s) = sᵃ (T − s)ᵃ` with `a = smoothness`, over
    /// `window` samples (odd, more than `2a`) taken every `step` seconds; `smoothness` must be
    /// at least `order` (and 1), so that the boundary terms vanish.
    pub fn new(
        order: u32,
        smoothness: u32,
        window: usize,
        step: f64,
    ) -> Result<Self, EstimatorError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(EstimatorError::Step(step));
        }
        if smoothness < order.max(1) {
            return Err(EstimatorError::Degree {
                degree: smoothness,
                order,
            });
        }
        if window % 2 == 0 || window <= 2 * smoothness as usize {
            return Err(EstimatorError::Window(window));
        }
        let span = (window - 1) as f64 * step;
        let a = smoothness as usize;
        // g(u) = uᵃ (1 − u)ᵃ = Σᵢ C(a, i) (−1)ⁱ uᵃ⁺ⁱ by its coefficients in u, then its
        // derivatives and its first two antiderivatives from 0.
        let mut g = vec![0.0; 2 * a + 1];
        let mut binomial = 1.0;
        for i in 0..=a {
            g[a + i] = if i % 2 == 0 { binomial } else { -binomial };
            binomial = binomial * (a - i) as f64 / (i + 1) as f64;
        }
        let integrate = |c: &[f64]| -> Vec<f64> {
            core::iter::once(0.0)
                .chain(c.iter().enumerate().map(|(p, c)| c / (p + 1) as f64))
                .collect()
        };
        let (g1, g2) = (integrate(&g), integrate(&integrate(&g)));
        let value = |c: &[f64], u: f64| c.iter().rev().fold(0.0, |acc, &c| acc * u + c);
        let (area1, area2) = (value(&g1, 1.0), value(&g2, 1.0));
        // Ψₘ(s) = φ⁽ᵐ⁾(s) for m ≥ −2 on the whole line: φ and its derivatives below order a
        // vanish outside the window, its antiderivatives stay at their last values (the
        // second grows there as a line).
        let psi = |m: i32, derivative: &[f64], s: f64| -> f64 {
            let u = s / span;
            match m {
                -2 if u > 1.0 => span * span * (area2 + area1 * (u - 1.0)),
                -2 => span * span * value(&g2, u.max(0.0)),
                -1 => span * value(&g1, u.clamp(0.0, 1.0)),
                _ if !(0.0..=1.0).contains(&u) => 0.0,
                m => value(derivative, u) / span.powi(m),
            }
        };
        // The estimate of order k is (−1)ᵏ ∫ φ⁽ᵏ⁾ x̂ / ∫ φ with x̂ the samples joined by lines:
        // against a hat function, that is the second difference of φ⁽ᵏ⁻²⁾, so the estimates
        // are the exact derivatives of one smooth average of x̂.
        let area = span * area1;
        let mut weights = Vec::with_capacity(window * (order as usize + 1));
        let mut derivative = g.clone();
        for k in 0..=order as i32 {
            let m = k - 2;
            if m > 0 {
                derivative = (derivative.iter().enumerate().skip(1))
                    .map(|(p, c)| p as f64 * c)
                    .collect();
            }
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let at = |j: f64| psi(m, &derivative, j * step);
            weights.extend((0..window).map(|j| {
                let j = j as f64;
                sign * (at(j + 1.0) - 2.0 * at(j) + at(j - 1.0)) / step / area
            }));
        }
        Ok(ModulatingFunction {
            fir: Fir::new(weights, window, order),
            delay: span / 2.0,
        })
    }
}

impl Differentiator for ModulatingFunction {
    fn push(&mut self, x: f64) -> Option<&[f64]> {
        self.fir.push(x)
    }

    fn push_slice(&mut self, xs: &[f64], out: &mut [f64]) -> usize {
        self.fir.push_slice(xs, out)
    }

    fn delay(&self) -> f64 {
        self.delay
    }

    fn order(&self) -> u32 {
        self.fir.order()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a sine of frequency 1 every estimate is the weighted average's derivative: the
    /// sine's, at the window's centre, scaled by `φ`'s (real, symmetric) transform at 1.
    #[test]
    fn each_order_is_the_derivative_of_the_weighted_average() {
        let (h, window) = (1e-3, 1001);
        let mut f = ModulatingFunction::new(4, 5, window, h).expect("valid");
        // φ's transform at 1: the weighted average of a unit sine is that times the sine.
        let centre = (window - 1) as f64 / 2.0;
        let g: f64 = (f.fir.row(0).unwrap_or_default().iter().enumerate())
            .map(|(j, w)| w * ((j as f64 - centre) * h).cos())
            .sum();
        let mut worst = [0.0f64; 5];
        for k in 0..6000 {
            let t = k as f64 * h;
            let delay = f.delay();
            let Some(d) = f.push(t.sin()) else { continue };
            let at = t - delay;
            for (order, (w, v)) in worst.iter_mut().zip(d).enumerate() {
                let want = g * (at + order as f64 * core::f64::consts::FRAC_PI_2).sin();
                *w = w.max((v - want).abs());
            }
        }
        assert!(worst.iter().all(|&w| w < 1e-9), "{worst:?}");
    }

    /// A linear ODE holds on the estimates: for `x'' + 2x' + x = u`, the estimates of
    /// `x'' + 2x' + x` equal those of `u`, with any window, up to the smoothed error of
    /// joining the samples by lines.
    #[test]
    fn a_linear_relation_holds_on_the_estimates() {
        let h = 1e-3;
        for window in [21, 201, 2001] {
            let mut fx = ModulatingFunction::new(2, 3, window, h).expect("valid");
            let mut fu = ModulatingFunction::new(0, 3, window, h).expect("valid");
            let mut worst = 0.0f64;
            for k in 0..5000 {
                let t = k as f64 * h;
                // x = e^{-t} sin 3t: u = x'' + 2x' + x = -9 e^{-t} sin 3t.
                let x = (-t).exp() * (3.0 * t).sin();
                let (Some(x), Some(u)) = (fx.push(x), fu.push(-9.0 * x)) else {
                    continue;
                };
                worst = worst.max((x[2] + 2.0 * x[1] + x[0] - u[0]).abs());
            }
            // The joined samples' error, smoothed: it falls as the window's span to the fourth.
            let bound = 2e-4 * (20.0 / (window - 1) as f64).powi(4);
            assert!(worst < bound, "window {window}: {worst} against {bound}");
        }
    }

    /// Bad arguments are refused with the reason.
    #[test]
    fn bad_windows_are_refused() {
        let degree = |d, o| {
            Some(EstimatorError::Degree {
                degree: d,
                order: o,
            })
        };
        assert_eq!(ModulatingFunction::new(3, 2, 101, 1e-3).err(), degree(2, 3));
        let window = |w| Some(EstimatorError::Window(w));
        assert_eq!(ModulatingFunction::new(1, 2, 100, 1e-3).err(), window(100));
        assert_eq!(ModulatingFunction::new(1, 3, 5, 1e-3).err(), window(5));
        let step = Some(EstimatorError::Step(0.0));
        assert_eq!(ModulatingFunction::new(1, 2, 101, 0.0).err(), step);
    }
}
