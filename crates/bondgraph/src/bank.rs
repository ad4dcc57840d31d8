//! Several signals sampled together, estimated together.

use crate::prelude::*;

use crate::differentiate::{check_fit, fit_weights};
use crate::differentiate::{Differentiator, EstimatorError};
use crate::window::Window;

/// Estimates `C` signals sampled at the same instants: each sample is one value per signal,
/// each estimate `out[k][c]` the `k`-th derivative of signal `c`, for `k` up to
/// [`Bank::order`]. A residual generator pushes all its raw signals (and their integrals)
/// through one bank, so that every term of an ARR is filtered alike.
pub trait Bank<const C: usize> {
    /// Takes the next sample of every signal and returns the estimates by order, at the
    /// newest sample minus [`Bank::delay`], once enough samples were seen.
    fn push(&mut self, x: [f64; C]) -> Option<&[[f64; C]]>;

    /// How far the estimates lag the newest sample, in seconds.
    fn delay(&self) -> f64;

    /// The highest derivative estimated for every signal.
    fn order(&self) -> u32;
}

/// One Savitzky–Golay fit (see [`SavitzkyGolay`](crate::SavitzkyGolay)) applied to `C`
/// signals at once: the signals share the window and the weights, and are stored side by
/// side, so that each weight is loaded once for all of them and the arithmetic runs across
/// signals. Same estimates, to rounding, as `C` separate fits.
///
/// Only the first `D` signals get derivatives (the others read zero above order 0): a
/// residual generator puts the signals whose derivatives its ARRs read first, and saves the
/// fits nobody reads.
#[derive(Clone, Debug)]
pub struct SavitzkyGolayBank<const C: usize, const D: usize = C> {
    /// `weights[k·window + j]`: the k-th derivative's weight of the j-th oldest sample.
    weights: Vec<f64>,
    window: usize,
    /// The last `window` samples of every signal.
    samples: Window<[f64; C]>,
    out: Vec<[f64; C]>,
    delay: f64,
}

impl<const C: usize, const D: usize> SavitzkyGolayBank<C, D> {
    /// The signals' values and, for the first `D` (at most `C`), derivatives up to `order`, from a polynomial of `degree` over `window`
    /// samples taken every `step` seconds, evaluated at the window's centre when `centred`
    /// (then `window` must be odd) or else at its newest sample.
    pub fn new(
        order: u32,
        degree: u32,
        window: usize,
        step: f64,
        centred: bool,
    ) -> Result<Self, EstimatorError> {
        const { assert!(D <= C, "a bank differentiates at most all of its signals") };
        let at = check_fit(order, degree, window, step, centred)?;
        let weights =
            fit_weights(order, degree, window, at, step).ok_or(EstimatorError::Window(window))?;
        Ok(SavitzkyGolayBank {
            weights: weights.concat(),
            window,
            samples: Window::new(window, [0.0; C]),
            out: vec![[0.0; C]; order as usize + 1],
            delay: (window - 1 - at) as f64 * step,
        })
    }
}

impl<const C: usize, const D: usize> Bank<C> for SavitzkyGolayBank<C, D> {
    fn push(&mut self, x: [f64; C]) -> Option<&[[f64; C]]> {
        let window = self.window;
        let samples = self.samples.push(x)?;
        let (values, derivatives) = self.out.split_at_mut(1);
        values[0] = weighted_sum::<C, C>(samples, &self.weights[..window]);
        let mut row = window;
        for out in derivatives {
            *out = weighted_sum::<C, D>(samples, &self.weights[row..row + window]);
            row += window;
        }
        Some(&self.out)
    }

    fn delay(&self) -> f64 {
        self.delay
    }

    fn order(&self) -> u32 {
        self.out.len() as u32 - 1
    }
}

/// `Σⱼ wⱼ sⱼ` for the first `N` of the `C` signals, zero for the others, running the
/// arithmetic across signals. Four running sums per signal: with few signals, one sum would
/// wait on each addition, and that latency, not the arithmetic, would set the cost.
#[inline]
fn weighted_sum<const C: usize, const N: usize>(samples: &[[f64; C]], weights: &[f64]) -> [f64; C] {
    let n = N.min(C);
    let mut sums = [[0.0; C]; 4];
    let whole = samples.len().min(weights.len()) / 4 * 4;
    let quads = samples[..whole]
        .chunks_exact(4)
        .zip(weights[..whole].chunks_exact(4));
    for (s, w) in quads {
        for ((sum, s), w) in sums.iter_mut().zip(s).zip(w) {
            for (acc, v) in sum[..n].iter_mut().zip(s) {
                *acc += w * v;
            }
        }
    }
    // The last samples apart, added last: the additions of a single fit (`Fir`, which `bgc
    // residuals` runs), so that the bank's estimates are a fit's to the bit. (`-0.0` is the
    // sum of nothing, as `Iterator::sum` starts.)
    let mut rest = [-0.0; C];
    for (s, w) in samples[whole..].iter().zip(&weights[whole..]) {
        for (acc, v) in rest[..n].iter_mut().zip(s) {
            *acc += v * w;
        }
    }
    core::array::from_fn(|c| (sums[0][c] + sums[1][c]) + (sums[2][c] + sums[3][c]) + rest[c])
}

/// `C` estimators of any kind side by side, one per signal, each to an order of its own:
/// the bank of estimators that are not Savitzky–Golay fits (a
/// [`StateVariableFilter`](crate::StateVariableFilter) per signal, say). Orders a signal's
/// estimator does not give read zero.
#[derive(Clone, Debug)]
pub struct Each<D, const C: usize> {
    estimators: Vec<D>,
    out: Vec<[f64; C]>,
    ready: bool,
}

impl<D: Differentiator, const C: usize> Each<D, C> {
    /// A bank whose signal `c` is estimated by `estimator(orders[c])`.
    pub fn new<E>(
        orders: [u32; C],
        mut estimator: impl FnMut(u32) -> Result<D, E>,
    ) -> Result<Self, E> {
        let estimators = orders
            .iter()
            .map(|&n| estimator(n))
            .collect::<Result<Vec<D>, E>>()?;
        let top = estimators.iter().map(D::order).max().unwrap_or(0);
        Ok(Each {
            estimators,
            out: vec![[0.0; C]; top as usize + 1],
            ready: false,
        })
    }
}

impl<D: Differentiator, const C: usize> Bank<C> for Each<D, C> {
    fn push(&mut self, x: [f64; C]) -> Option<&[[f64; C]]> {
        let mut ready = true;
        for (c, (estimator, v)) in self.estimators.iter_mut().zip(x).enumerate() {
            match estimator.push(v) {
                Some(d) => {
                    for (out, &e) in self.out.iter_mut().zip(d) {
                        out[c] = e;
                    }
                }
                None => ready = false,
            }
        }
        // Once every window is full it stays full.
        self.ready |= ready;
        self.ready.then_some(&self.out[..])
    }

    fn delay(&self) -> f64 {
        self.estimators.iter().map(D::delay).fold(0.0, f64::max)
    }

    fn order(&self) -> u32 {
        self.out.len() as u32 - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{SavitzkyGolay, StateVariableFilter};

    /// The bank gives the numbers separate fits give, signal by signal, order by order, to the
    /// bit.
    #[test]
    fn a_bank_estimates_each_signal_as_its_own_fit_would() {
        let h = 1e-3;
        let mut bank = SavitzkyGolayBank::<3>::new(2, 3, 11, h, true).expect("valid");
        let mut single: Vec<SavitzkyGolay> = (0..3)
            .map(|_| SavitzkyGolay::new(2, 3, 11, h, true).expect("valid"))
            .collect();
        assert_eq!(bank.delay(), single[0].delay());
        let mut compared = 0;
        for k in 0..500 {
            let t = k as f64 * h;
            let x = [(3.0 * t).sin(), t * t - 1.0, (20.0 * t).cos() + 0.1 * t];
            let got = bank.push(x).map(<[[f64; 3]]>::to_vec);
            for (c, fit) in single.iter_mut().enumerate() {
                let want = fit.push(x[c]).map(<[f64]>::to_vec);
                assert_eq!(got.is_some(), want.is_some(), "sample {k}");
                if let (Some(g), Some(w)) = (&got, want) {
                    for (order, w) in w.iter().enumerate() {
                        let g = g[order][c];
                        assert_eq!(g.to_bits(), w.to_bits(), "{k} {c} {order}");
                        compared += 1;
                    }
                }
            }
        }
        assert_eq!(compared, (500 - 10) * 3 * 3);
    }

    /// Signals past the first `D` get their value only; the first `D` every derivative.
    #[test]
    fn only_the_first_signals_are_differentiated() {
        let h = 1e-2;
        let mut bank = SavitzkyGolayBank::<3, 1>::new(1, 2, 5, h, true).expect("valid");
        let mut last = None;
        for k in 0..20 {
            let t = k as f64 * h;
            last = bank.push([t, 2.0 * t, 3.0 * t]).map(<[[f64; 3]]>::to_vec);
        }
        let d = last.expect("full");
        let at = 19.0 * h - bank.delay();
        for c in 0..3 {
            assert!((d[0][c] - (c + 1) as f64 * at).abs() < 1e-12, "{d:?}");
        }
        assert!((d[1][0] - 1.0).abs() < 1e-9 && d[1][1] == 0.0 && d[1][2] == 0.0);
    }

    /// A bank of filters estimates each signal to its own order, zero above it.
    #[test]
    fn each_signal_keeps_its_estimator_and_its_order() {
        let h = 1e-3;
        let filter = |order| StateVariableFilter::new(order, 100.0, 0.7, h);
        let mut bank = Each::<_, 2>::new([0, 2], filter).expect("valid");
        let mut alone = filter(2).expect("valid");
        assert_eq!(bank.order(), 2);
        for k in 0..100 {
            let t = k as f64 * h;
            let got = bank.push([1.0, t.sin()]).expect("filters need no window");
            let want = alone.push(t.sin()).expect("no window");
            assert!((got[0][0] - 1.0).abs() < 1e-12, "a constant stays put");
            assert_eq!(got[2][0], 0.0);
            assert_eq!(
                [got[0][1], got[1][1], got[2][1]],
                [want[0], want[1], want[2]]
            );
        }
    }

    #[test]
    fn an_impossible_bank_is_refused_as_a_fit_is() {
        assert_eq!(
            SavitzkyGolayBank::<2>::new(1, 2, 10, 0.1, true).err(),
            Some(EstimatorError::Window(10))
        );
        assert_eq!(
            SavitzkyGolayBank::<2>::new(3, 2, 11, 0.1, true).err(),
            Some(EstimatorError::Degree {
                degree: 2,
                order: 3
            })
        );
    }
}
