//! Time derivatives of sampled signals.

use crate::prelude::*;

use core::fmt;

use crate::fir::Fir;

/// Estimates a signal's value and time derivatives from samples at a uniform step. Every
/// estimator is linear in its samples (the estimates of a sum are the sums of the
/// estimates): calibration draws noise through the estimators once and adds it both ways.
pub trait Differentiator {
    /// Takes the next sample and returns the estimates of the signal and its derivatives,
    /// orders 0 to [`Differentiator::order`], at the evaluation time (the newest sample minus
    /// [`Differentiator::delay`]), once enough samples were seen.
    fn push(&mut self, x: f64) -> Option<&[f64]>;

    /// How far the estimates lag the newest sample, in seconds.
    fn delay(&self) -> f64;

    /// The highest derivative estimated.
    fn order(&self) -> u32;

    /// [`Differentiator::push`] of each of `xs` in turn, for a caller that holds many
    /// samples: the estimate of order `k` after sample `i` goes to `out[k·xs.len() + i]`
    /// (`out` holds `(order + 1)·xs.len()` values). Returns how many of the first samples
    /// gave no estimate; their entries are left as they were. An estimator gives estimates
    /// from some sample on, then one after every sample.
    fn push_slice(&mut self, xs: &[f64], out: &mut [f64]) -> usize {
        let n = xs.len();
        let mut skip = 0;
        for (i, &x) in xs.iter().enumerate() {
            match self.push(x) {
                Some(d) => {
                    for (v, column) in d.iter().zip(out.chunks_exact_mut(n)) {
                        column[i] = *v;
                    }
                }
                // Whatever came before is not an estimate either: nothing is made up.
                None => skip = i + 1,
            }
        }
        skip
    }
}

/// Why an estimator cannot be built as asked.
#[derive(Clone, Debug, PartialEq)]
pub enum EstimatorError {
    /// The sampling step is not a positive number.
    Step(f64),
    /// A Savitzky–Golay fit of this degree cannot give this derivative order.
    Degree {
        /// The polynomial's degree.
        degree: u32,
        /// The derivative asked for.
        order: u32,
    },
    /// The window holds fewer samples than the polynomial has coefficients, or is even for
    /// a centred fit.
    Window(usize),
    /// The state-variable filter gives derivatives up to the second only.
    FilterOrder(u32),
    /// The filter's cutoff or damping is not a positive number.
    Filter,
    /// The estimator gives derivatives up to `order`; what it feeds reads up to `needed`.
    Order {
        /// The highest derivative the estimator gives.
        order: u32,
        /// The highest derivative read.
        needed: u32,
    },
}

impl fmt::Display for EstimatorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EstimatorError::Step(h) => write!(f, "the sampling step must be positive, not {h}"),
            EstimatorError::Degree { degree, order } => write!(
                f,
                "a polynomial of degree {degree} has no derivative of order {order}: use a degree of at least {order}"
            ),
            EstimatorError::Window(w) => write!(
                f,
                "a window of {w} samples cannot hold the fit (it needs more samples than coefficients, and an odd count when centred)"
            ),
            EstimatorError::FilterOrder(n) => write!(
                f,
                "the second-order state-variable filter gives derivatives up to order 2, not {n}: use a Savitzky-Golay fit"
            ),
            EstimatorError::Filter => write!(f, "the filter's cutoff and damping must be positive"),
            EstimatorError::Order { order, needed } => write!(
                f,
                "the estimator gives derivatives up to order {order}, but order {needed} is read"
            ),
        }
    }
}

impl core::error::Error for EstimatorError {}

/// A Savitzky–Golay differentiator: a least-squares polynomial of degree `d` fitted to the
/// last `w` samples, differentiated at the window's centre (delay `(w−1)/2` samples, the
/// most accurate) or at its newest sample (no delay, noisier). On a signal whose `(d+1)`-th
/// derivative is bounded by `M`, the k-th derivative is off by at most about
/// `M (w h)^(d+1−k)` times a constant of the window, and white noise of deviation `σ` gives
/// about `σ / (w^(k+1/2) h^k)`: widen the window against noise, narrow it against bias.
#[derive(Clone, Debug)]
pub struct SavitzkyGolay {
    /// The fit's weights over the last `window` samples.
    fir: Fir,
    delay: f64,
    degree: u32,
    /// `|t_j − t_eval|^(degree+1)` of each sample of the window, in seconds.
    reach: Vec<f64>,
}

impl SavitzkyGolay {
    /// Derivatives up to `order` from a polynomial of `degree` over `window` samples taken
    /// every `step` seconds, evaluated at the window's centre when `centred` (then `window`
    /// must be odd) or else at its newest sample.
    pub fn new(
        order: u32,
        degree: u32,
        window: usize,
        step: f64,
        centred: bool,
    ) -> Result<SavitzkyGolay, EstimatorError> {
        let at = check_fit(order, degree, window, step, centred)?;
        let weights =
            fit_weights(order, degree, window, at, step).ok_or(EstimatorError::Window(window))?;
        let reach = (0..window)
            .map(|j| ((j as f64 - at as f64).abs() * step).powi(degree as i32 + 1))
            .collect();
        Ok(SavitzkyGolay {
            fir: Fir::new(weights.concat(), window, order),
            delay: (window - 1 - at) as f64 * step,
            degree,
            reach,
        })
    }

    /// A bound on the error of the `k`-th derivative estimate for a noise-free signal whose
    /// derivative of order `degree + 1` stays within `±max_next` over the window: the fit is
    /// exact on polynomials of its degree, so only each sample's Taylor remainder,
    /// `max_next |t_j − t|^(d+1) / (d+1)!`, passes through the weights.
    #[must_use]
    pub fn error_bound(&self, k: u32, max_next: f64) -> f64 {
        let factorial: f64 = (1..=self.degree + 1).map(f64::from).product();
        self.fir.row(k).map_or(f64::INFINITY, |w| {
            w.iter()
                .zip(&self.reach)
                .map(|(w, r)| w.abs() * r)
                .sum::<f64>()
                * max_next
                / factorial
        })
    }
}

/// Checks that a fit can be built and returns the sample it is evaluated at.
pub(crate) fn check_fit(
    order: u32,
    degree: u32,
    window: usize,
    step: f64,
    centred: bool,
) -> Result<usize, EstimatorError> {
    if !(step.is_finite() && step > 0.0) {
        return Err(EstimatorError::Step(step));
    }
    if degree < order {
        return Err(EstimatorError::Degree { degree, order });
    }
    if window <= degree as usize || (centred && window % 2 == 0) {
        return Err(EstimatorError::Window(window));
    }
    Ok(if centred {
        (window - 1) / 2
    } else {
        window - 1
    })
}

/// The weights that give derivatives `0..=order` at sample `at` of a degree-`degree` least
/// squares fit over `window` samples: rows of `(VᵀV)⁻¹Vᵀ`, scaled to seconds. Positions are
/// scaled to about ±1 so that the normal equations stay well conditioned.
pub(crate) fn fit_weights(
    order: u32,
    degree: u32,
    window: usize,
    at: usize,
    step: f64,
) -> Option<Vec<Vec<f64>>> {
    let n = degree as usize + 1;
    let scale = ((window - 1) as f64 / 2.0).max(1.0);
    let tau: Vec<f64> = (0..window)
        .map(|j| (j as f64 - at as f64) / scale)
        .collect();
    let power = |x: f64, k: usize| x.powi(k as i32);
    // Normal equations (VᵀV) X = Vᵀ, solved for all samples at once.
    let mut a: Vec<Vec<f64>> = (0..n)
        .map(|r| {
            (0..n)
                .map(|c| tau.iter().map(|&t| power(t, r + c)).sum())
                .collect()
        })
        .collect();
    let mut x: Vec<Vec<f64>> = (0..n)
        .map(|r| tau.iter().map(|&t| power(t, r)).collect())
        .collect();
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, pivot);
        x.swap(col, pivot);
        for r in 0..n {
            if r == col {
                continue;
            }
            let f = a[r][col] / a[col][col];
            if f == 0.0 {
                continue;
            }
            let (pivot_a, pivot_x) = (a[col].clone(), x[col].clone());
            for (v, p) in a[r].iter_mut().zip(&pivot_a) {
                *v -= f * p;
            }
            for (v, p) in x[r].iter_mut().zip(&pivot_x) {
                *v -= f * p;
            }
        }
    }
    let mut factorial = 1.0;
    let mut out = Vec::with_capacity(order as usize + 1);
    for k in 0..=order as usize {
        if k > 0 {
            factorial *= k as f64;
        }
        // d^k/dt^k of Σ c_i τ^i at τ = 0 is k! c_k, and τ is t / (scale·step).
        let factor = factorial / (scale * step).powi(k as i32) / a[k][k];
        out.push(x[k].iter().map(|w| w * factor).collect());
    }
    Some(out)
}

impl Differentiator for SavitzkyGolay {
    fn push(&mut self, x: f64) -> Option<&[f64]> {
        self.fir.push(x)
    }

    fn delay(&self) -> f64 {
        self.delay
    }

    fn order(&self) -> u32 {
        self.fir.order()
    }

    fn push_slice(&mut self, xs: &[f64], out: &mut [f64]) -> usize {
        self.fir.push_slice(xs, out)
    }
}

/// A second-order state-variable filter `ω² / (s² + 2ζω s + ω²)` whose states are the
/// filtered signal and its first derivative, the second following from the filter's
/// equation: derivatives up to order 2, with no window to fill. Discretised exactly for an
/// input linear between samples. At frequencies `w` well below `ω` the outputs are the
/// signal's delayed by `2ζ/ω` seconds, to within about `(w/ω)³` relative with `ζ = 1/√2`
/// (the flattest gain); the second derivative also carries the sampling's error, about
/// `(ωh)²/8 |u''|`, so keep `ωh` small. Components above `ω` are attenuated by 40 dB per
/// decade.
#[derive(Clone, Debug)]
pub struct StateVariableFilter {
    /// `x ← Φ x + Γ₀ u_k + Γ₁ (u_{k+1} − u_k)/h`.
    phi: [[f64; 2]; 2],
    gamma0: [f64; 2],
    gamma1: [f64; 2],
    omega: f64,
    zeta: f64,
    step: f64,
    state: [f64; 2],
    last: Option<f64>,
    out: Vec<f64>,
}

impl StateVariableFilter {
    /// Derivatives up to `order` (at most 2) with cutoff `omega` (rad/s) and damping `zeta`
    /// (1/√2 for the flattest response), for samples every `step` seconds.
    pub fn new(order: u32, omega: f64, zeta: f64, step: f64) -> Result<Self, EstimatorError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(EstimatorError::Step(step));
        }
        if order > 2 {
            return Err(EstimatorError::FilterOrder(order));
        }
        if !(omega.is_finite() && omega > 0.0 && zeta.is_finite() && zeta > 0.0) {
            return Err(EstimatorError::Filter);
        }
        // exp(M h) with the input and its slope as two more states: [x1, x2, u, u'].
        let w2 = omega * omega;
        let m = [
            vec![0.0, 1.0, 0.0, 0.0],
            vec![-w2, -2.0 * zeta * omega, w2, 0.0],
            vec![0.0, 0.0, 0.0, 1.0],
            vec![0.0, 0.0, 0.0, 0.0],
        ];
        let e = expm(&m, step);
        Ok(StateVariableFilter {
            phi: [[e[0][0], e[0][1]], [e[1][0], e[1][1]]],
            gamma0: [e[0][2], e[1][2]],
            gamma1: [e[0][3], e[1][3]],
            omega,
            zeta,
            step,
            state: [0.0; 2],
            last: None,
            out: vec![0.0; order as usize + 1],
        })
    }
}

/// `exp(m h)` of a square matrix by scaling and squaring a Taylor series.
pub(crate) fn expm(m: &[Vec<f64>], h: f64) -> Vec<Vec<f64>> {
    let n = m.len();
    let norm: f64 = m.iter().flatten().map(|v| v.abs()).sum::<f64>() * h;
    let squarings = norm.max(1.0).log2().ceil() as i32 + 1;
    let scale = h / 2f64.powi(squarings);
    let mul = |a: &[Vec<f64>], b: &[Vec<f64>]| -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| a[i][k] * b[k][j]).sum())
                    .collect()
            })
            .collect()
    };
    let a: Vec<Vec<f64>> = m
        .iter()
        .map(|row| row.iter().map(|v| v * scale).collect())
        .collect();
    let identity: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let mut term = identity.clone();
    let mut sum = identity;
    for k in 1..=20 {
        term = mul(&term, &a)
            .into_iter()
            .map(|row| row.into_iter().map(|v| v / f64::from(k)).collect())
            .collect();
        for (srow, trow) in sum.iter_mut().zip(&term) {
            for (s, t) in srow.iter_mut().zip(trow) {
                *s += t;
            }
        }
    }
    for _ in 0..squarings {
        sum = mul(&sum, &sum);
    }
    sum
}

impl Differentiator for StateVariableFilter {
    fn push(&mut self, x: f64) -> Option<&[f64]> {
        match self.last {
            // Start at rest on the first sample, so that a constant signal gives no transient.
            None => self.state = [x, 0.0],
            Some(u) => {
                let slope = (x - u) / self.step;
                let [x1, x2] = self.state;
                self.state = [0, 1].map(|i| {
                    self.phi[i][0] * x1
                        + self.phi[i][1] * x2
                        + self.gamma0[i] * u
                        + self.gamma1[i] * slope
                });
            }
        }
        self.last = Some(x);
        let [x1, x2] = self.state;
        let w2 = self.omega * self.omega;
        let values = [x1, x2, w2 * (x - x1) - 2.0 * self.zeta * self.omega * x2];
        for (o, v) in self.out.iter_mut().zip(values) {
            *o = v;
        }
        Some(&self.out)
    }

    fn delay(&self) -> f64 {
        2.0 * self.zeta / self.omega
    }

    fn order(&self) -> u32 {
        self.out.len() as u32 - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimates of a slice, from each kind of estimator, are those of its samples
    /// pushed one at a time, to the bit, wherever the slices are cut.
    #[test]
    fn a_slice_is_its_samples_pushed_in_turn() {
        let xs: Vec<f64> = (0..120).map(|k| (k as f64 * 0.03).sin()).collect();
        let kinds: [fn() -> Box<dyn Differentiator>; 3] = [
            || Box::new(SavitzkyGolay::new(2, 3, 11, 0.01, true).expect("valid")),
            || Box::new(crate::ModulatingFunction::new(2, 3, 11, 0.01).expect("valid")),
            || Box::new(StateVariableFilter::new(2, 50.0, 0.7, 0.01).expect("valid")),
        ];
        for make in kinds {
            let mut one = make();
            let single: Vec<Option<Vec<u64>>> = (xs.iter())
                .map(|&x| one.push(x).map(|d| d.iter().map(|v| v.to_bits()).collect()))
                .collect();
            for cut in [1usize, 3, 10, 50] {
                let mut many = make();
                for (c, chunk) in xs.chunks(cut).enumerate() {
                    let mut out = vec![f64::NAN; 3 * chunk.len()];
                    let skip = many.push_slice(chunk, &mut out);
                    for (i, expected) in single[c * cut..][..chunk.len()].iter().enumerate() {
                        let got = (i >= skip)
                            .then(|| (0..3).map(|k| out[k * chunk.len() + i].to_bits()).collect());
                        assert_eq!(&got, expected, "cut {cut}, sample {}", c * cut + i);
                    }
                }
            }
        }
    }

    /// A fit of degree d is exact on polynomials of degree d, centred or at the end, for
    /// every derivative up to the order asked.
    #[test]
    fn savitzky_golay_is_exact_on_polynomials_of_its_degree() {
        let h = 0.01;
        let p = |t: f64| {
            [
                1.0 - 2.0 * t + 3.0 * t * t - t * t * t,
                -2.0 + 6.0 * t - 3.0 * t * t,
                6.0 - 6.0 * t,
                -6.0,
            ]
        };
        for centred in [true, false] {
            let mut sg = SavitzkyGolay::new(3, 3, 11, h, centred).expect("valid");
            let mut last = None;
            for k in 0..40 {
                let t = k as f64 * h;
                last = sg.push(p(t)[0]).map(<[f64]>::to_vec).or(last);
            }
            let at = 39.0 * h - sg.delay();
            let want = p(at);
            let got = last.expect("full window");
            for k in 0..4 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-7 * (1.0 + want[k].abs()),
                    "centred {centred}, order {k}: {} vs {}",
                    got[k],
                    want[k]
                );
            }
        }
    }

    /// On sin(t), a centred quadratic fit over 21 samples at h = 1 ms, delayed by 10 samples:
    /// its first derivative is off by y''' h² Σk⁴/(6 Σk²) (k = -10..10), 1.1e-5, its
    /// second by about y'''' h² Σk⁴/(12 Σk²)-ish terms, well under 1e-3.
    #[test]
    fn savitzky_golay_differentiates_a_sine_with_its_stated_delay() {
        let h = 1e-3;
        let mut sg = SavitzkyGolay::new(2, 2, 21, h, true).expect("valid");
        assert!((sg.delay() - 10.0 * h).abs() < 1e-15);
        let mut worst = [0.0f64; 3];
        let delay = sg.delay();
        for k in 0..2000 {
            let t = k as f64 * h;
            if let Some(d) = sg.push(t.sin()) {
                let at = t - delay;
                let want = [at.sin(), at.cos(), -at.sin()];
                for i in 0..3 {
                    worst[i] = worst[i].max((d[i] - want[i]).abs());
                }
            }
        }
        let bound = h * h * 25_333.0 / (6.0 * 385.0);
        assert!(
            worst[1] < bound * 1.01 && worst[1] > bound * 0.9,
            "{worst:?} against {bound}"
        );
        assert!(worst[0] < 1e-4 && worst[2] < 1e-3, "{worst:?}");
    }

    /// Far below its cutoff, the filter follows sin(t) and its derivatives with the lag it
    /// states, to about (w/ω)² = 2.5e-5 relative, plus the next term of the delay's
    /// expansion.
    #[test]
    fn the_state_variable_filter_follows_slow_signals_with_its_stated_delay() {
        let h = 1e-3;
        let omega = 200.0;
        let mut f =
            StateVariableFilter::new(2, omega, core::f64::consts::FRAC_1_SQRT_2, h).expect("valid");
        let mut worst = [0.0f64; 3];
        for k in 0..6000 {
            let t = k as f64 * h;
            let d = f.push(t.sin()).expect("no window").to_vec();
            if t > 1.0 {
                let at = t - f.delay();
                let want = [at.sin(), at.cos(), -at.sin()];
                for i in 0..3 {
                    worst[i] = worst[i].max((d[i] - want[i]).abs());
                }
            }
        }
        // The filter sees the input linear between samples, off by h²/8 |u''|; its second
        // derivative, ω²(u − y) − 2ζω y', multiplies that by ω².
        let second = (omega * h).powi(2) / 8.0;
        assert!(worst[0] < 2e-7 && worst[1] < 2e-7, "{worst:?}");
        assert!(worst[2] < second * 1.01, "{worst:?} against {second}");
    }

    /// The stated bound holds on a sine (every derivative within ±1). It is conservative: a
    /// centred window cancels the odd remainders, so the first derivative is far better.
    #[test]
    fn the_error_bound_holds_and_is_tight() {
        let h = 1e-2;
        let mut sg = SavitzkyGolay::new(2, 3, 15, h, true).expect("valid");
        let delay = sg.delay();
        let mut worst = [0.0f64; 3];
        for k in 0..2000 {
            let t = k as f64 * h;
            if let Some(d) = sg.push(t.sin()) {
                let at = t - delay;
                let want = [at.sin(), at.cos(), -at.sin()];
                for i in 0..3 {
                    worst[i] = worst[i].max((d[i] - want[i]).abs());
                }
            }
        }
        for (k, w) in worst.iter().enumerate() {
            let bound = sg.error_bound(k as u32, 1.0);
            assert!(*w <= bound, "order {k}: {w} against {bound}");
        }
    }

    #[test]
    fn impossible_estimators_are_refused() {
        assert_eq!(
            SavitzkyGolay::new(3, 2, 11, 0.1, true).err(),
            Some(EstimatorError::Degree {
                degree: 2,
                order: 3
            })
        );
        assert_eq!(
            SavitzkyGolay::new(1, 2, 10, 0.1, true).err(),
            Some(EstimatorError::Window(10))
        );
        assert_eq!(
            SavitzkyGolay::new(1, 2, 2, 0.1, false).err(),
            Some(EstimatorError::Window(2))
        );
        assert_eq!(
            SavitzkyGolay::new(1, 2, 5, 0.0, false).err(),
            Some(EstimatorError::Step(0.0))
        );
        assert_eq!(
            StateVariableFilter::new(3, 1.0, 0.7, 0.1).err(),
            Some(EstimatorError::FilterOrder(3))
        );
    }
}
