//! Derivatives through a chain of identical first-order lags: the Poisson moment
//! functionals of system identification.

use crate::differentiate::expm;
use crate::{Differentiator, EstimatorError};

/// A low-pass filter `(ω/(s + ω))ⁿ` whose output's derivatives up to order `n` are exact
/// combinations of its `n` lags: `y⁽ᵏ⁾ = ωᵏ Σⱼ C(k, j) (−1)ᵏ⁻ʲ w₍ₙ₋ⱼ₎` with `w₀` the input, so
/// no signal is differentiated numerically.
///
/// Why it suits ARRs: every signal of an ARR goes through the same filter `L`, and `L`
/// commutes with differentiation, so an ARR that is linear in the signals and their
/// derivatives with constant coefficients gives exactly `L(ARR) = 0` on a healthy plant,
/// with no fit error whatever the cutoff; the cutoff then only trades noise for how fast a
/// fault shows (about `n/ω` seconds). An ARR with signal-dependent coefficients holds to the
/// extent the coefficients change slowly against `n/ω`.
///
/// Discretised exactly for an input linear between samples. The derivative of order `k`
/// amplifies white noise by about `ωᵏ` up to the cutoff and rolls it off above when `n > k`:
/// take `n` one above the highest order read.
#[derive(Clone, Debug)]
pub struct PoissonFilter {
    /// `w ← Φ w + Γ₀ u_k + Γ₁ (u_{k+1} − u_k)/h`, for the lags `w₁ … wₙ`.
    phi: Vec<Vec<f64>>,
    gamma0: Vec<f64>,
    gamma1: Vec<f64>,
    /// `ωᵏ C(k, j) (−1)ᵏ⁻ʲ` for each output order `k` and `j = 0..=k`.
    weights: Vec<Vec<f64>>,
    step: f64,
    lags: Vec<f64>,
    scratch: Vec<f64>,
    last: Option<f64>,
    out: Vec<f64>,
}

impl PoissonFilter {
    /// Derivatives up to `order` of `(ω/(s + ω))^degree` applied to samples every `step`
    /// seconds, with cutoff `omega` (rad/s); `degree` must be at least `order` and 1.
    pub fn new(order: u32, degree: u32, omega: f64, step: f64) -> Result<Self, EstimatorError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(EstimatorError::Step(step));
        }
        if degree < order.max(1) {
            return Err(EstimatorError::Order {
                order: degree,
                needed: order,
            });
        }
        if !(omega.is_finite() && omega > 0.0) {
            return Err(EstimatorError::Filter);
        }
        let n = degree as usize;
        // The lags, then the input and its slope as two more states.
        let mut m = vec![vec![0.0; n + 2]; n + 2];
        for (i, row) in m.iter_mut().enumerate().take(n) {
            row[i] = -omega;
            // The first lag follows the input, the others the lag before.
            row[if i == 0 { n } else { i - 1 }] = omega;
        }
        m[n][n + 1] = 1.0;
        let e = expm(&m, step);
        let weights = (0..=order as i32)
            .map(|k| {
                let mut c = 1.0;
                (0..=k)
                    .map(|j| {
                        let w = omega.powi(k) * c * if (k - j) % 2 == 0 { 1.0 } else { -1.0 };
                        c = c * f64::from(k - j) / f64::from(j + 1);
                        w
                    })
                    .collect()
            })
            .collect();
        Ok(PoissonFilter {
            phi: e[..n].iter().map(|row| row[..n].to_vec()).collect(),
            gamma0: e[..n].iter().map(|row| row[n]).collect(),
            gamma1: e[..n].iter().map(|row| row[n + 1]).collect(),
            weights,
            step,
            lags: vec![0.0; n],
            scratch: vec![0.0; n],
            last: None,
            out: vec![0.0; order as usize + 1],
        })
    }
}

impl Differentiator for PoissonFilter {
    fn push(&mut self, x: f64) -> Option<&[f64]> {
        match self.last {
            // Start at rest on the first sample, so that a constant signal gives no transient.
            None => self.lags.iter_mut().for_each(|w| *w = x),
            Some(u) => {
                let slope = (x - u) / self.step;
                for (i, next) in self.scratch.iter_mut().enumerate() {
                    let row = &self.phi[i];
                    *next = row.iter().zip(&self.lags).map(|(a, w)| a * w).sum::<f64>()
                        + self.gamma0[i] * u
                        + self.gamma1[i] * slope;
                }
                std::mem::swap(&mut self.lags, &mut self.scratch);
            }
        }
        self.last = Some(x);
        let n = self.lags.len();
        // `w₀` is the input; `wₙ` the output.
        let lag = |i: usize| if i == 0 { x } else { self.lags[i - 1] };
        for (out, weights) in self.out.iter_mut().zip(&self.weights) {
            *out = weights
                .iter()
                .enumerate()
                .map(|(j, c)| c * lag(n - j))
                .sum();
        }
        Some(&self.out)
    }

    /// 0: the estimates are the filtered signal's derivatives at the newest sample. The
    /// filtered signal itself lags the signal by about `n/ω` at frequencies below the cutoff,
    /// so a residual on filtered signals shows a fault over the following `n/ω` seconds, and
    /// never before it.
    fn delay(&self) -> f64 {
        0.0
    }

    fn order(&self) -> u32 {
        self.out.len() as u32 - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a sine of frequency 1, every output is the sine filtered by `(ω/(s+ω))ⁿ` and
    /// differentiated: gain `(ω/√(1+ω²))ⁿ`, phase `−n atan(1/ω)`, times `iᵏ`.
    #[test]
    fn derivatives_are_the_filtered_sine_s() {
        let (h, omega, n) = (1e-3, 8.0, 5);
        let mut f = PoissonFilter::new(4, n, omega, h).expect("valid");
        let gain = (omega / (1.0 + omega * omega).sqrt()).powi(n as i32);
        let phase = -f64::from(n) * (1.0 / omega).atan();
        let mut worst = [0.0f64; 5];
        for k in 0..20_000 {
            let t = k as f64 * h;
            let d = f.push(t.sin()).expect("no window").to_vec();
            // After the start's transient (e^{-ωt} with polynomial factors) has died.
            if t > 10.0 {
                for (order, (w, v)) in worst.iter_mut().zip(d).enumerate() {
                    let want =
                        gain * (t + phase + order as f64 * std::f64::consts::FRAC_PI_2).sin();
                    *w = w.max((v - want).abs());
                }
            }
        }
        // The sampling's error grows with the order as (ωh)² ωᵏ, about 1e-4 at order 4.
        assert!(worst.iter().all(|&w| w < 2e-4), "{worst:?}");
        assert!(worst[0] < 1e-6, "{worst:?}");
    }

    /// A linear ODE holds on the filtered signals: for `x'' + 2x' + x = u`, the filtered
    /// `x'' + 2x' + x` equals the filtered `u`, at any cutoff.
    #[test]
    fn a_linear_relation_holds_exactly_on_filtered_signals() {
        let h = 1e-3;
        for omega in [0.5, 5.0, 50.0] {
            let mut fx = PoissonFilter::new(2, 3, omega, h).expect("valid");
            let mut fu = PoissonFilter::new(0, 3, omega, h).expect("valid");
            // x = t³ solves it with u = 6t + 6t² + t³; the samples are linear between samples
            // only to O(h²), which bounds the error.
            let mut worst = 0.0f64;
            for k in 0..5000 {
                let t = k as f64 * h;
                let x = fx.push(t.powi(3)).expect("x").to_vec();
                let u = fu.push(6.0 * t + 6.0 * t * t + t.powi(3)).expect("u")[0];
                if k > 0 {
                    worst = worst.max((x[2] + 2.0 * x[1] + x[0] - u).abs() / (1.0 + u.abs()));
                }
            }
            assert!(worst < 1e-5, "ω = {omega}: {worst}");
        }
    }

    /// Bad arguments are refused with the reason.
    #[test]
    fn bad_filters_are_refused() {
        assert_eq!(
            PoissonFilter::new(3, 2, 1.0, 1e-3).err(),
            Some(EstimatorError::Order {
                order: 2,
                needed: 3
            })
        );
        assert_eq!(
            PoissonFilter::new(1, 2, 0.0, 1e-3).err(),
            Some(EstimatorError::Filter)
        );
        assert_eq!(
            PoissonFilter::new(1, 2, 1.0, -1.0).err(),
            Some(EstimatorError::Step(-1.0))
        );
    }
}
