//! A copy of the model run alongside recorded samples, for simulated residuals.

use crate::prelude::*;

use alloc::collections::VecDeque;

/// A copy of a model driven by recorded inputs: its state follows `dx/dt = f(t, x, u)` with
/// the inputs linear between samples, one classic Runge–Kutta step per sample interval
/// (error O(h⁴) per unit time for smooth dynamics), and is read at any instant between the
/// oldest sample still needed and the newest.
///
/// A simulated residual compares a measured signal with this copy's output at the instant
/// the derivative estimators refer to, some samples behind the newest: the copy keeps its
/// states since then, and no more.
#[derive(Clone, Debug)]
pub struct Replay {
    x: Vec<f64>,
    last: Option<(f64, Vec<f64>)>,
    history: VecDeque<(f64, Vec<f64>)>,
    scratch: [Vec<f64>; 5],
    substeps: usize,
}

impl Replay {
    /// A copy starting from the state `x0` at the first sample.
    #[must_use]
    pub fn new(x0: &[f64]) -> Replay {
        let n = x0.len();
        Replay {
            x: x0.to_vec(),
            last: None,
            history: VecDeque::new(),
            scratch: core::array::from_fn(|_| vec![0.0; n]),
            substeps: 1,
        }
    }

    /// Takes `n` Runge–Kutta steps per sample interval (at least 1; 1 is the default, what
    /// the generated code does), the inputs still linear between samples: for a copy whose
    /// motion is fast against the samples (a resonance at 9 samples per period, where one
    /// step a sample turns the phase by a radian over a thousand samples), fitted by its
    /// simulation error.
    pub fn set_substeps(&mut self, n: usize) {
        self.substeps = n.max(1);
    }

    /// Takes the inputs `u` sampled at `t` and advances the state to `t`; `rates(t, x, u, dx)`
    /// writes the state's derivative into `dx`.
    pub fn push(
        &mut self,
        t: f64,
        u: &[f64],
        mut rates: impl FnMut(f64, &[f64], &[f64], &mut [f64]),
    ) {
        if let Some((t0, u0)) = self.last.take() {
            if self.substeps == 1 {
                self.step(t0, &u0, t - t0, u, &mut rates);
            } else {
                let n = self.substeps as f64;
                let h = (t - t0) / n;
                let at = |i: usize| -> Vec<f64> {
                    let w = i as f64 / n;
                    u0.iter().zip(u).map(|(a, b)| a + w * (b - a)).collect()
                };
                for i in 0..self.substeps {
                    let (ua, ub) = (at(i), at(i + 1));
                    self.step(t0 + i as f64 * h, &ua, h, &ub, &mut rates);
                }
            }
        }
        self.last = Some((t, u.to_vec()));
        self.history.push_back((t, self.x.clone()));
    }

    /// One RK4 step of length `h` from `t0`, the inputs going from `u0` to `u1`.
    fn step(
        &mut self,
        t0: f64,
        u0: &[f64],
        h: f64,
        u1: &[f64],
        rates: &mut impl FnMut(f64, &[f64], &[f64], &mut [f64]),
    ) {
        let mid: Vec<f64> = u0.iter().zip(u1).map(|(a, b)| 0.5 * (a + b)).collect();
        let [k1, k2, k3, k4, y] = &mut self.scratch;
        rates(t0, &self.x, u0, k1);
        for ((y, x), k) in y.iter_mut().zip(&self.x).zip(k1.iter()) {
            *y = x + 0.5 * h * k;
        }
        rates(t0 + 0.5 * h, y, &mid, k2);
        for ((y, x), k) in y.iter_mut().zip(&self.x).zip(k2.iter()) {
            *y = x + 0.5 * h * k;
        }
        rates(t0 + 0.5 * h, y, &mid, k3);
        for ((y, x), k) in y.iter_mut().zip(&self.x).zip(k3.iter()) {
            *y = x + h * k;
        }
        rates(t0 + h, y, u1, k4);
        for (i, x) in self.x.iter_mut().enumerate() {
            *x += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }

    /// The state at `at`, linear between samples; `None` before the oldest sample kept or
    /// after the newest. States before `at` are forgotten: `at` must not go back.
    pub fn at(&mut self, at: f64) -> Option<Vec<f64>> {
        while self.history.len() >= 2 && self.history[1].0 <= at {
            self.history.pop_front();
        }
        let (t0, x0) = self.history.front()?;
        if at < *t0 {
            return None;
        }
        let Some((t1, x1)) = self.history.get(1) else {
            return (at == *t0).then(|| x0.clone());
        };
        let w = (at - t0) / (t1 - t0);
        Some(x0.iter().zip(x1).map(|(a, b)| a + w * (b - a)).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `dx/dt = u − x` driven by `u = t` from `x(0) = 0` has `x = t − 1 + e^{−t}`: the copy
    /// follows it to RK4's accuracy, read between samples too.
    #[test]
    fn a_first_order_lag_follows_its_exact_solution() {
        let h = 0.01;
        let mut copy = Replay::new(&[0.0]);
        let exact = |t: f64| t - 1.0 + (-t).exp();
        for k in 0..=300 {
            let t = f64::from(k) * h;
            copy.push(t, &[t], |_, x, u, dx| dx[0] = u[0] - x[0]);
            if k >= 10 {
                let at = t - 0.055;
                let x = copy.at(at).expect("kept")[0];
                // Linear interpolation between samples dominates: h² max|x''| / 8.
                assert!((x - exact(at)).abs() < 2e-5, "t = {at}: {x}");
            }
        }
        assert!(copy.history.len() <= 8);
        assert_eq!(copy.at(-1.0), None);
    }

    /// An undamped oscillator sampled 9 times a period: one step a sample loses phase and
    /// amplitude over a hundred periods, eight steps a sample hold them.
    #[test]
    fn substeps_hold_a_fast_oscillation() {
        let w = core::f64::consts::TAU;
        let h = 1.0 / 9.0;
        let run = |n: usize| {
            let mut copy = Replay::new(&[1.0, 0.0]);
            copy.set_substeps(n);
            for k in 0..=900 {
                copy.push(f64::from(k) * h, &[], |_, x, _, dx| {
                    dx[0] = x[1];
                    dx[1] = -w * w * x[0];
                });
            }
            copy.at(100.0).expect("kept")[0]
        };
        // cos(2π · 100) = 1.
        assert!((run(1) - 1.0).abs() > 0.05, "{}", run(1));
        assert!((run(8) - 1.0).abs() < 1e-3, "{}", run(8));
    }
}
