//! The size of a fault: how far one parameter has moved, estimated sample by sample from the
//! residuals once a class alarms.
//!
//! Around a point `θ̂`, each residual is linear in the parameter to first order,
//! `r(θ) ≈ r(θ̂) + s·(θ − θ̂)` with `s = ∂r/∂θ` at `θ̂`; the change `Δ = θ − θ̂` that makes
//! them vanish is a least-squares problem in one unknown, solved recursively with
//! exponential forgetting ([`ChangeEstimator`]), so that the estimate follows a fault that
//! drifts. [`FaultSize`] gets `r` and `s` from two copies of a residual generator, one at
//! `θ̂` and one a small step away (a difference, exact where the relation is linear in the
//! parameter, as most are: resistances, inertias, frictions, offsets), and moves `θ̂` to its
//! estimate when that has gone further than the linearisation holds (a dead zone tripled).
//! Ranking candidates by what a change of theirs alone leaves of the residuals
//! ([`Change::misfit`]) tells apart components one signature cannot. The estimate lags a
//! drift by about the memory (a time constant of `memory` samples).

use crate::prelude::*;

/// A residual generator whose parameters can be set by place: what [`FaultSize`] runs at
/// the point it linearises around. The generated `ResidualGenerator` implements it.
pub trait Parametrised: Clone {
    /// How many parameters.
    fn parameter_count(&self) -> usize;
    /// Parameter `k`'s value.
    fn parameter(&self, k: usize) -> f64;
    /// Sets parameter `k`; the generator keeps its estimators' and integrals' state.
    fn set_parameter(&mut self, k: usize, value: f64);
    /// How many residuals.
    fn residual_count(&self) -> usize;
    /// Takes one sample of the raw signals at `t` and writes the residuals into `residuals`;
    /// `false` while the estimators' windows fill.
    fn push_raw(&mut self, t: f64, raw: &[f64], residuals: &mut [f64]) -> bool;
}

/// Why a size estimator cannot be set up.
#[derive(Clone, Debug, PartialEq)]
pub enum SizeError {
    /// A residual's noise level is not a positive number.
    Noise(usize, f64),
    /// The memory is shorter than two samples.
    Memory(usize),
    /// No parameter at that place.
    Parameter(usize),
    /// One noise level per residual is needed.
    Residuals {
        /// How many noise levels were given.
        noise: usize,
        /// How many residuals the generator has.
        residuals: usize,
    },
}

impl core::fmt::Display for SizeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SizeError::Noise(k, x) => write!(
                f,
                "residual {k}'s noise level is {x}: expected a positive number (its healthy RMS, or its threshold over 3)"
            ),
            SizeError::Memory(n) => {
                write!(f, "a memory of {n} samples: expected at least 2")
            }
            SizeError::Parameter(k) => write!(f, "no parameter at place {k}"),
            SizeError::Residuals { noise, residuals } => write!(
                f,
                "{noise} noise levels for {residuals} residuals: expected one per residual"
            ),
        }
    }
}

impl core::error::Error for SizeError {}

/// One parameter's estimated change from a point, as [`ChangeEstimator::change`] gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Change {
    /// The change from the point linearised around.
    pub delta: f64,
    /// The half-width of its 95 % interval (normal, with the residuals' correlation over
    /// [`ChangeEstimator::with_correlation`] samples allowed for).
    pub half_width: f64,
    /// The RMS of what the change leaves of the residuals, over the memory, in units of
    /// their noise: about 1 when a change of this parameter alone explains every residual,
    /// more when it does not (rank candidates by it, lowest first).
    pub misfit: f64,
    /// The effective number of samples the estimate rests on.
    pub samples: f64,
}

/// Recursive least squares in one unknown, with exponential forgetting: the change `Δ`
/// minimising `Σ λ^(n−k) Σᵢ wᵢ (rᵢ,ₖ + sᵢ,ₖ Δ)²`, each residual weighted by the inverse of
/// its noise variance. The forgetting goes by information: a sample forgets `λ` raised to
/// the information it brings (`Σᵢ wᵢ sᵢ²`) over the mean a sample has brought, so that the
/// memory is `memory` samples of typical information, and a stretch that says nothing
/// about the parameter forgets nothing.
#[derive(Clone, Debug)]
pub struct ChangeEstimator {
    weights: Vec<f64>,
    forgetting: f64,
    correlation: f64,
    ss: f64,
    sr: f64,
    rr: f64,
    count: f64,
    /// The mean information `s'Ws` a sample has brought, over every sample.
    information: f64,
    seen: f64,
}

impl ChangeEstimator {
    /// An estimator for residuals of healthy RMS `noise` (one each), forgetting with a time
    /// constant of `memory` samples (`λ = 1 − 1/memory`).
    pub fn new(noise: &[f64], memory: usize) -> Result<ChangeEstimator, SizeError> {
        if memory < 2 {
            return Err(SizeError::Memory(memory));
        }
        let weights = (noise.iter().enumerate())
            .map(|(k, &x)| {
                if x.is_finite() && x > 0.0 {
                    Ok(1.0 / (x * x))
                } else {
                    Err(SizeError::Noise(k, x))
                }
            })
            .collect::<Result<Vec<f64>, SizeError>>()?;
        Ok(ChangeEstimator {
            weights,
            forgetting: 1.0 - 1.0 / memory as f64,
            correlation: 1.0,
            ss: 0.0,
            sr: 0.0,
            rr: 0.0,
            count: 0.0,
            information: 0.0,
            seen: 0.0,
        })
    }

    /// Successive residuals are correlated over `samples` samples (an estimator's window):
    /// the interval widens by its square root, as if there were that many fewer samples.
    #[must_use]
    pub fn with_correlation(mut self, samples: usize) -> ChangeEstimator {
        self.correlation = samples.max(1) as f64;
        self
    }

    /// Takes one sample's residuals `r` and their sensitivities `s` to the parameter.
    /// A sample holding a non-finite value is skipped.
    pub fn push(&mut self, r: &[f64], s: &[f64]) {
        let (mut ss, mut sr, mut rr) = (0.0, 0.0, 0.0);
        for ((&w, &r), &s) in self.weights.iter().zip(r).zip(s) {
            ss += w * s * s;
            sr += w * s * r;
            rr += w * r * r;
        }
        if !(ss.is_finite() && sr.is_finite() && rr.is_finite()) {
            return;
        }
        // Forgetting by information rather than by time: a stretch where the residuals do
        // not depend on the parameter (a dead zone the twist does not cross) forgets
        // nothing, else the estimate would wander on noise alone until the next crossing.
        self.seen += 1.0;
        self.information += (ss - self.information) / self.seen;
        let exponent = if self.information > 0.0 {
            (ss / self.information).min(MAX_FORGET)
        } else {
            1.0
        };
        let l = self.forgetting.powf(exponent);
        self.ss = l * self.ss + ss;
        self.sr = l * self.sr + sr;
        self.rr = l * self.rr + rr;
        self.count = l * self.count + 1.0;
    }

    /// The change that best explains the residuals so far, once they depend on the
    /// parameter at all.
    #[must_use]
    pub fn change(&self) -> Option<Change> {
        if self.ss <= 0.0 || self.count < 2.0 {
            return None;
        }
        let delta = -self.sr / self.ss;
        let left = (self.rr - self.sr * self.sr / self.ss).max(0.0);
        // The residuals' spread about the fit, per sample, in units of their noise.
        let spread = left / (self.count - 1.0);
        let half_width = 1.96 * (spread * self.correlation / self.ss).sqrt();
        Some(Change {
            delta,
            half_width,
            misfit: (spread / self.weights.len().max(1) as f64).sqrt(),
            samples: self.count,
        })
    }

    /// The time constant of the forgetting, in samples.
    #[must_use]
    pub fn memory(&self) -> f64 {
        1.0 / (1.0 - self.forgetting)
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        self.ss = 0.0;
        self.sr = 0.0;
        self.rr = 0.0;
        self.count = 0.0;
    }
}

/// One parameter's value estimated sample by sample from a residual generator's residuals:
/// see the module's documentation.
#[derive(Clone, Debug)]
pub struct FaultSize<G> {
    parameter: usize,
    point: f64,
    step: f64,
    base: G,
    probe: G,
    estimator: ChangeEstimator,
    relinearise: f64,
    settling: usize,
    skip: usize,
    held: Size,
    r: Vec<f64>,
    rp: Vec<f64>,
    s: Vec<f64>,
}

/// A parameter's estimate, as [`FaultSize::estimate`] gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Size {
    /// The parameter's estimated value.
    pub value: f64,
    /// The half-width of its 95 % interval (see [`Change::half_width`]).
    pub half_width: f64,
    /// What the change leaves of the residuals, in units of their noise (see
    /// [`Change::misfit`]); infinite before the residuals depend on the parameter.
    pub misfit: f64,
}

impl<G: Parametrised> FaultSize<G> {
    /// Sizes parameter `parameter` of `generator` (fresh, with the model's values: it is
    /// copied, never pushed), on residuals of healthy RMS `noise`, forgetting over `memory`
    /// samples.
    pub fn new(
        generator: &G,
        parameter: usize,
        noise: &[f64],
        memory: usize,
    ) -> Result<FaultSize<G>, SizeError> {
        if parameter >= generator.parameter_count() {
            return Err(SizeError::Parameter(parameter));
        }
        let residuals = generator.residual_count();
        if noise.len() != residuals {
            return Err(SizeError::Residuals {
                noise: noise.len(),
                residuals,
            });
        }
        let point = generator.parameter(parameter);
        let (base, probe, step) = pair(generator, parameter, point);
        Ok(FaultSize {
            parameter,
            point,
            step,
            base,
            probe,
            estimator: ChangeEstimator::new(noise, memory)?,
            relinearise: 0.05,
            settling: crate::reference::Reference::DEFAULT_WINDOW,
            skip: 0,
            held: Size {
                value: point,
                half_width: f64::INFINITY,
                misfit: f64::INFINITY,
            },
            r: vec![0.0; residuals],
            rp: vec![0.0; residuals],
            s: vec![0.0; residuals],
        })
    }

    /// Successive residuals are correlated over `samples` samples (see
    /// [`ChangeEstimator::with_correlation`]).
    #[must_use]
    pub fn with_correlation(mut self, samples: usize) -> FaultSize<G> {
        self.estimator = self.estimator.with_correlation(samples);
        self
    }

    /// After the point moves, the residuals are left out for `samples` samples: those of
    /// an ARR realised by integration are a change over the generator's integration window
    /// (by default `Reference::DEFAULT_WINDOW`, the
    /// default here), which holds values computed at the old point until it has passed.
    #[must_use]
    pub fn with_settling(mut self, samples: usize) -> FaultSize<G> {
        self.settling = samples;
        self
    }

    /// The parameter's place.
    #[must_use]
    pub fn parameter(&self) -> usize {
        self.parameter
    }

    /// Takes one sample of the raw signals at `t`.
    pub fn push(&mut self, t: f64, raw: &[f64]) {
        let a = self.base.push_raw(t, raw, &mut self.r);
        let b = self.probe.push_raw(t, raw, &mut self.rp);
        if !(a && b) {
            return;
        }
        if self.skip > 0 {
            self.skip -= 1;
            return;
        }
        for ((s, &rp), &r) in self.s.iter_mut().zip(&self.rp).zip(&self.r) {
            *s = (rp - r) / self.step;
        }
        self.estimator.push(&self.r, &self.s);
        self.hold();
        self.follow();
    }

    /// Keeps the estimate when it is informative: its interval within a tenth of the
    /// parameter's scale, from a tenth of a memory of samples at least. Between, the last such one stands (after a stretch where the
    /// residuals hardly depend on the parameter, a few noisy samples would move it far).
    fn hold(&mut self) {
        let Some(c) = self.estimator.change() else {
            return;
        };
        // An interval needs the residuals' spread from several of their correlation
        // lengths: over fewer, it is as noisy as the estimate.
        let enough = (4.0 * self.estimator.correlation).max(0.1 * self.estimator.memory());
        if c.samples >= enough && c.half_width <= INFORMATIVE * self.scale() && c.delta.is_finite()
        {
            self.held = Size {
                value: self.point + c.delta,
                half_width: c.half_width,
                misfit: c.misfit,
            };
        }
    }

    /// The parameter's scale: its value where it is not 0.
    fn scale(&self) -> f64 {
        if self.point == 0.0 {
            self.step / STEP
        } else {
            self.point.abs()
        }
    }

    /// Moves the point linearised around to the estimate once that has gone further than
    /// a linearisation is trusted, further than its interval, and rests on half a memory
    /// of samples (a dead zone's parameter shows only while the twist crosses it: a few
    /// samples' estimate is noise). The copies of the generator go on with the new point
    /// (not afresh: their integrals of the signals from the start, such as the bench's
    /// twist, must stay those of the record) once their integration window has passed.
    fn follow(&mut self) {
        let Some(c) = self.estimator.change() else {
            return;
        };
        let scale = self.scale();
        let settled = c.samples >= 0.5 * self.estimator.memory();
        let beyond = c.delta.abs() > self.relinearise * scale && c.delta.abs() > c.half_width;
        if settled && beyond && c.delta.is_finite() {
            self.point += c.delta;
            self.step = step_at(self.point);
            self.base.set_parameter(self.parameter, self.point);
            (self.probe).set_parameter(self.parameter, self.point + self.step);
            self.estimator.reset();
            self.skip = self.settling;
        }
    }

    /// The last informative estimate: the point linearised around moved by the change the
    /// residuals ask for, once its interval is within a tenth of the parameter's value
    /// (the model's value, with an infinite interval, until then).
    #[must_use]
    pub fn estimate(&self) -> Size {
        self.held
    }
}

/// How narrow, relative to the parameter's value, an estimate's interval must be for
/// [`FaultSize::estimate`] to give it.
const INFORMATIVE: f64 = 0.1;

/// The most a sample of unusual information forgets, in samples of typical information.
const MAX_FORGET: f64 = 20.0;

/// The relative step of the difference that gives the sensitivities.
const STEP: f64 = 1e-4;

/// The step of the difference at `point`.
fn step_at(point: f64) -> f64 {
    if point == 0.0 {
        STEP
    } else {
        STEP * point.abs()
    }
}

/// Copies of `template` with parameter `k` at `point` and a step away, and the step.
fn pair<G: Parametrised>(template: &G, k: usize, point: f64) -> (G, G, f64) {
    let step = step_at(point);
    let mut base = template.clone();
    base.set_parameter(k, point);
    let mut probe = template.clone();
    probe.set_parameter(k, point + step);
    (base, probe, step)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A generator of the relations `y − tanh(θ·u) = 0` (nonlinear in θ) and `z − θ·u = 0`,
    /// on raw samples `[u, y, z]`.
    #[derive(Clone, Debug)]
    struct Toy {
        theta: f64,
        pushed: usize,
    }

    impl Parametrised for Toy {
        fn parameter_count(&self) -> usize {
            1
        }
        fn parameter(&self, _: usize) -> f64 {
            self.theta
        }
        fn set_parameter(&mut self, _: usize, value: f64) {
            self.theta = value;
        }
        fn residual_count(&self) -> usize {
            2
        }
        fn push_raw(&mut self, _: f64, raw: &[f64], residuals: &mut [f64]) -> bool {
            // A window of three samples to fill, as an estimator's would.
            self.pushed += 1;
            residuals[0] = raw[1] - (self.theta * raw[0]).tanh();
            residuals[1] = raw[2] - self.theta * raw[0];
            self.pushed > 3
        }
    }

    /// A reproducible noise sample in [-1, 1).
    fn noise(k: usize) -> f64 {
        let x = (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
        2.0 * (x as f64 / (1u64 << 53) as f64) - 1.0
    }

    fn sample(k: usize, theta: f64) -> (f64, [f64; 3]) {
        let t = k as f64 * 1e-3;
        let u = 2.0 * (3.0 * t).sin() + 0.5 * (11.0 * t).sin();
        let y = (theta * u).tanh() + 1e-3 * noise(2 * k);
        let z = theta * u + 1e-3 * noise(2 * k + 1);
        (t, [u, y, z])
    }

    #[test]
    fn a_linear_change_is_recovered_with_its_interval() {
        let mut e = ChangeEstimator::new(&[1e-3], 1_000_000).expect("valid");
        for k in 0..2000 {
            let s = 1.0 + (k as f64 * 0.01).sin();
            e.push(&[-0.3 * s + 1e-3 * noise(k)], &[s]);
        }
        let c = e.change().expect("estimate");
        assert!((c.delta - 0.3).abs() < c.half_width, "{c:?}");
        assert!(c.half_width < 1e-3, "{c:?}");
        assert!((c.misfit - 1.0 / 3f64.sqrt()).abs() < 0.05, "{c:?}");
    }

    #[test]
    fn a_tripled_parameter_is_followed_past_its_linearisation() {
        let mut size = FaultSize::new(
            &Toy {
                theta: 0.2,
                pushed: 0,
            },
            0,
            &[1e-3, 1e-3],
            500,
        )
        .expect("valid");
        for k in 0..5000 {
            let (t, raw) = sample(k, 0.6);
            size.push(t, &raw);
        }
        let s = size.estimate();
        assert!((s.value - 0.6).abs() < 1e-3, "{s:?}");
        assert!((s.value - 0.6).abs() < s.half_width.max(1e-4), "{s:?}");
        // Uniform noise of half-width 1e-3 has an RMS of 1e-3/√3 of the level given.
        assert!(s.misfit < 0.7, "{s:?}");
    }

    #[test]
    fn a_drifting_parameter_is_followed() {
        let mut size = FaultSize::new(
            &Toy {
                theta: 0.2,
                pushed: 0,
            },
            0,
            &[1e-3, 1e-3],
            300,
        )
        .expect("valid");
        let mut worst: f64 = 0.0;
        for k in 0..20_000 {
            let theta = 0.2 + 0.4 * k as f64 / 20_000.0;
            let (t, raw) = sample(k, theta);
            size.push(t, &raw);
            if k > 2000 && k % 100 == 0 {
                worst = worst.max((size.estimate().value / theta - 1.0).abs());
            }
        }
        // The estimate lags by about the memory: 300 samples of a drift of 2e-5 a sample.
        assert!(worst < 0.05, "{worst}");
    }

    #[test]
    fn bad_settings_are_refused() {
        let toy = Toy {
            theta: 1.0,
            pushed: 0,
        };
        assert_eq!(
            FaultSize::new(&toy, 0, &[1e-3, 0.0], 100).err(),
            Some(SizeError::Noise(1, 0.0))
        );
        assert_eq!(
            FaultSize::new(&toy, 0, &[1e-3], 100).err(),
            Some(SizeError::Residuals {
                noise: 1,
                residuals: 2
            })
        );
        assert_eq!(
            FaultSize::new(&toy, 3, &[1e-3, 1e-3], 100).err(),
            Some(SizeError::Parameter(3))
        );
        assert_eq!(
            FaultSize::new(&toy, 0, &[1e-3, 1e-3], 1).err(),
            Some(SizeError::Memory(1))
        );
    }
}
