// Residual code for the model `hardening_spring` (models/hardening_spring.bg), written by bgc.
// It needs the `bondgraph` runtime crate.

#[allow(unused_imports)]
use ::bondgraph::Real as _;
/// The model's parameters; [`Default`] gives the values the model declares.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub struct Params {
    /// `m` [kg]: mass (model value 1)
    pub m: f64,
    /// `k1` [N/m]: spring stiffness at rest (model value 40)
    pub k1: f64,
    /// `k3` [N/m^3]: spring hardening (model value 400)
    pub k3: f64,
    /// `b` [N.s/m]: viscous damping (model value 0.5)
    pub b: f64,
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Default for Params {
    fn default() -> Self {
        Params {
            m: 1.0,
            k1: 40.0,
            k3: 400.0,
            b: 0.5,
        }
    }
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Params {
    /// How far each parameter's true value may be from the model's (`+- 5%` in the
    /// model), as a half-width in its unit; 0 for those it states exactly.
    pub const UNCERTAINTY: Params = Params {
        m: 0.0,
        k1: 0.0,
        k3: 0.0,
        b: 0.0,
    };
    /// The fields' names, in order.
    pub const NAMES: [&'static str; 4] = ["m", "k1", "k3", "b"];
    /// The fields from an array in the order of [`Params::NAMES`].
    #[must_use]
    #[allow(non_snake_case)]
    pub fn from_array(a: [f64; 4]) -> Self {
        let [m, k1, k3, b] = a;
        Params { m, k1, k3, b }
    }
    /// The fields as an array in the order of [`Params::NAMES`].
    #[must_use]
    pub fn to_array(&self) -> [f64; 4] {
        [self.m, self.k1, self.k3, self.b]
    }
}
/// What the residuals read: the inputs and measured signals, their time derivatives
/// (`NAME_d1`, `NAME_d2`…) and integrals from the start of the record (`NAME_int`).
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub struct Signals {
    /// The input `F`.
    pub F: f64,
    /// The measured signal `v`.
    pub v: f64,
    /// The time derivative of order 1 of `v`.
    pub v_d1: f64,
    /// The integral of `v` from the start of the record.
    pub v_int: f64,
    /// The root of `k1 * q_spring + k3 * q_spring ^ 3 - (F - der(v) * m - b * v) = 0`: the law of `spring`, which has no closed-form inverse, solved at each estimate.
    pub q_spring: f64,
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Signals {
    /// The fields' names, in order.
    pub const NAMES: [&'static str; 5] = ["F", "v", "v_d1", "v_int", "q_spring"];
    /// The fields from an array in the order of [`Signals::NAMES`].
    #[must_use]
    #[allow(non_snake_case)]
    pub fn from_array(a: [f64; 5]) -> Self {
        let [F, v, v_d1, v_int, q_spring] = a;
        Signals {
            F,
            v,
            v_d1,
            v_int,
            q_spring,
        }
    }
    /// The fields as an array in the order of [`Signals::NAMES`].
    #[must_use]
    pub fn to_array(&self) -> [f64; 5] {
        [self.F, self.v, self.v_d1, self.v_int, self.q_spring]
    }
}
/// How many residuals [`residuals`] returns: one per ARR.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RESIDUAL_COUNT: usize = 1;
/// The ARRs' names, in the order of [`residuals`].
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RESIDUALS: [&str; 1] = ["ARR1"];
/// Whether each residual is simulated: it compares a measured signal with a copy of
/// the model run on the recorded inputs from rest, so it holds on a record that
/// starts with the machine at rest.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const SIMULATED: [bool; 1] = [false];
/// Whether each residual is realised by integration: the ARR `r = A + dF/dt` is
/// evaluated as the running value `F + ∫A` (what [`residuals`] returns for it), whose
/// change since a reference instant ([`bondgraph::Reference`]) is the residual
/// `∫ r dt`: it reads each derivative one order lower than the relation.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const INTEGRATED: [bool; 1] = [true];
/// Every ARR's residual, in the order of [`RESIDUALS`]; each is zero (up to the
/// estimation of the signals) while the machine is healthy. For a residual realised
/// by integration ([`INTEGRATED`]) it is the running value `F + ∫A`, whose change
/// since a reference instant is zero while the machine is healthy.
///
/// - ARR1: $$v - \dot{q}_{spring} = 0$$; integrated: the running value is $$-q_{spring} + \int_0^t v \, d\tau$$
#[allow(non_snake_case, unused_variables, clippy::all)]
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn residuals(p: &Params, s: &Signals) -> [f64; 1] {
    [-s.q_spring + s.v_int]
}
/// Each residual's bound from the uncertainty of the model's parameters at the signals
/// `s`: `Σ |∂r/∂θ| Δθ` over the uncertain parameters each ARR depends on, `Δθ` read
/// from `u` (usually [`Params::UNCERTAINTY`]). An adaptive threshold is this plus a
/// margin for noise; a healthy plant whose parameters are within `u` of `p` stays
/// under it to first order. An ARR that reads auxiliary signals, or one realised by
/// integration ([`INTEGRATED`]), has no bound (0): generate the code with
/// `realise = direct` (`--realise direct`) for adaptive thresholds.
#[allow(non_snake_case, unused_variables, clippy::all)]
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn bounds(p: &Params, u: &Params, s: &Signals) -> [f64; 1] {
    [0.0]
}
/// The fault signature matrix: which residuals a fault of each component moves.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const FSM: ::bondgraph::Fsm = ::bondgraph::Fsm {
    residuals: &RESIDUALS,
    components: &[
        ::bondgraph::Component {
            name: "force",
            kind: "Se",
            signature: ::bondgraph::Signature::new(1, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "mass",
            kind: "I",
            signature: ::bondgraph::Signature::new(1, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "spring",
            kind: "C",
            signature: ::bondgraph::Signature::new(1, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "damp",
            kind: "R",
            signature: ::bondgraph::Signature::new(1, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "v",
            kind: "Df",
            signature: ::bondgraph::Signature::new(1, &[0]),
            detectable: true,
            isolable: false,
        },
    ],
};
/// The components whose fault explains the residuals in alarm (see
/// [`bondgraph::Fsm::candidates`]).
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn candidates(alarms: &[bool; 1]) -> ::bondgraph::Vec<&'static str> {
    FSM.candidates(alarms)
}
/// The components whose fault is consistent with the residuals in alarm, with no
/// exoneration (see [`bondgraph::Fsm::suspects`]).
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn suspects(alarms: &[bool; 1]) -> ::bondgraph::Vec<&'static str> {
    FSM.suspects(alarms)
}
/// The raw signals [`ResidualGenerator::push`] takes, in order: the inputs and
/// measured signals the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RAW_SIGNALS: [&str; 2] = ["F", "v"];
/// The highest derivative of each raw signal the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RAW_ORDERS: [u32; 2] = [0, 1];
/// How many signals the generator's estimator bank takes: the raw signals whose
/// derivatives the ARRs read, the other raw signals, then the trapezoidal integrals of
/// those whose integral the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const CHANNELS: usize = 3;
/// How many of the bank's first [`CHANNELS`] need derivatives.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const DIFFERENTIATED: usize = 1;
/// The highest derivative the ARRs read of each of the bank's [`CHANNELS`] signals.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const CHANNEL_ORDERS: [u32; CHANNELS] = [1, 0, 0];
/// Residuals from raw samples. The raw signals and the trapezoidal integrals the ARRs
/// read go through one estimator bank (`B`), so that every term of an ARR is
/// filtered alike and refers to the same instant, [`ResidualGenerator::delay`]
/// seconds before the newest sample.
#[derive(Clone, Debug)]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub struct ResidualGenerator<
    B = ::bondgraph::SavitzkyGolayBank<CHANNELS, DIFFERENTIATED>,
> {
    params: Params,
    bank: B,
    integrals: [::bondgraph::Trapezoid; 1],
    others: [::bondgraph::Trapezoid; 0],
    roots: [::bondgraph::RootFinder; 1],
    unsolved: Option<&'static str>,
    references: [::bondgraph::Reference; 1],
    last: Signals,
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl<B: ::bondgraph::Bank<CHANNELS>> ResidualGenerator<B> {
    /// A generator over `bank`, which must estimate derivatives up to the highest
    /// order of [`CHANNEL_ORDERS`].
    pub fn with_bank(
        params: Params,
        bank: B,
    ) -> Result<Self, ::bondgraph::EstimatorError> {
        if bank.order() < 1 {
            return Err(::bondgraph::EstimatorError::Order {
                order: bank.order(),
                needed: 1,
            });
        }
        Ok(ResidualGenerator {
            params,
            bank,
            integrals: [::bondgraph::Trapezoid::new(); 1],
            others: [::bondgraph::Trapezoid::new(); 0],
            roots: [::bondgraph::RootFinder::new(); 1],
            unsolved: None,
            references: ::core::array::from_fn(|_| ::bondgraph::Reference::default()),
            last: Signals::default(),
        })
    }
    /// Residuals realised by integration ([`INTEGRATED`]) taken over the last
    /// `samples` steps (by default [`bondgraph::Reference::DEFAULT_WINDOW`]).
    #[must_use]
    pub fn with_integration_window(mut self, samples: usize) -> Self {
        self.references = ::core::array::from_fn(|_| ::bondgraph::Reference::window(
            samples,
        ));
        self
    }
    /// Residuals realised by integration ([`INTEGRATED`]) taken from the first
    /// estimate: a fault that shows only while a signal moves leaves them offset for
    /// good, and the noise they integrate grows with the record (see
    /// [`bondgraph::Reference`]).
    #[must_use]
    pub fn integrated_from_start(mut self) -> Self {
        self.references = ::core::array::from_fn(|_| ::bondgraph::Reference::from_start());
        self
    }
    /// The parameters the residuals are computed with.
    #[must_use]
    pub fn params(&self) -> &Params {
        &self.params
    }
    /// How far the residuals lag the newest sample, in seconds.
    #[must_use]
    pub fn delay(&self) -> f64 {
        self.bank.delay()
    }
    /// The root (a field of [`Signals`]) that had no solution at the last
    /// estimate, if any: the residuals that read it are not numbers there, and
    /// say nothing.
    #[must_use]
    pub fn unsolved(&self) -> Option<&'static str> {
        self.unsolved
    }
    /// The estimates the last residuals were computed from.
    #[must_use]
    pub fn signals(&self) -> &Signals {
        &self.last
    }
    /// The last residuals' bounds from the parameters' stated uncertainty
    /// ([`bounds`] with [`Params::UNCERTAINTY`]): add a margin for noise to get
    /// adaptive thresholds.
    #[must_use]
    pub fn bounds(&self) -> [f64; RESIDUAL_COUNT] {
        bounds(&self.params, &Params::UNCERTAINTY, &self.last)
    }
    /// Takes the samples of [`RAW_SIGNALS`] at time `t` (uniform steps) and returns
    /// the residuals at `t - self.delay()`, once the bank's windows are full.
    #[allow(unused_mut, unused_variables, clippy::all)]
    pub fn push(&mut self, t: f64, raw: [f64; 2]) -> Option<[f64; RESIDUAL_COUNT]> {
        let mut x = [0.0; CHANNELS];
        x[0] = raw[1];
        x[1] = raw[0];
        x[2] = self.integrals[0].push(t, raw[1]);
        let at = t - self.bank.delay();
        let [e0, e1, ..] = self.bank.push(x)? else {
            return None;
        };
        let p = &self.params;
        self.unsolved = None;
        let mut s = Signals::default();
        s.F = e0[1];
        s.v = e0[0];
        s.v_d1 = e1[0];
        s.v_int = e0[2];
        s.q_spring = match self
            .roots[0]
            .solve(|z| {
                s.q_spring = z;
                (
                    p.k1 * s.q_spring + p.k3 * s.q_spring.powi(3)
                        - (s.F - s.v_d1 * p.m - p.b * s.v),
                    p.k1 + p.k3 * 3.0 * s.q_spring.powi(2),
                )
            })
        {
            Some(z) => z,
            None => {
                self.unsolved = self.unsolved.or(Some("q_spring"));
                ::bondgraph::RootFinder::NO_ROOT
            }
        };
        let mut r = residuals(p, &s);
        r[0] = self.references[0].push(r[0]);
        self.last = s;
        Some(r)
    }
}
/// What [`bondgraph::FaultSize`] runs, at the parameter values it linearises
/// around, to size a fault once a class alarms.
#[allow(dead_code, unreachable_pub, clippy::all)]
impl<B: ::bondgraph::Bank<CHANNELS> + Clone> ::bondgraph::Parametrised
for ResidualGenerator<B> {
    fn parameter_count(&self) -> usize {
        Params::NAMES.len()
    }
    fn parameter(&self, k: usize) -> f64 {
        self.params.to_array()[k]
    }
    fn set_parameter(&mut self, k: usize, value: f64) {
        let mut a = self.params.to_array();
        a[k] = value;
        self.params = Params::from_array(a);
    }
    fn residual_count(&self) -> usize {
        RESIDUAL_COUNT
    }
    fn push_raw(&mut self, t: f64, raw: &[f64], residuals: &mut [f64]) -> bool {
        let Ok(raw) = <[f64; 2]>::try_from(raw) else {
            return false;
        };
        match self.push(t, raw) {
            Some(r) => {
                residuals[..RESIDUAL_COUNT].copy_from_slice(&r);
                true
            }
            None => false,
        }
    }
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl ResidualGenerator<::bondgraph::SavitzkyGolayBank<CHANNELS, DIFFERENTIATED>> {
    /// A generator with centred Savitzky–Golay fits of `degree` over `window` samples
    /// (odd) taken every `step` seconds: delay `(window − 1)/2` samples.
    pub fn savitzky_golay(
        params: Params,
        step: f64,
        window: usize,
        degree: u32,
    ) -> Result<Self, ::bondgraph::EstimatorError> {
        let bank = ::bondgraph::SavitzkyGolayBank::new(1, degree, window, step, true)?;
        Self::with_bank(params, bank)
    }
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl ResidualGenerator<::bondgraph::Each<::bondgraph::ModulatingFunction, CHANNELS>> {
    /// A generator with the same modulating function on every signal, over `window`
    /// samples (odd) taken every `step` seconds, of smoothness one above the highest
    /// derivative read: no signal is differentiated, and an ARR linear in the signals
    /// holds on the estimates at any window (see [`bondgraph::ModulatingFunction`]).
    pub fn modulating(
        params: Params,
        step: f64,
        window: usize,
    ) -> Result<Self, ::bondgraph::EstimatorError> {
        let bank = ::bondgraph::Each::new(
            CHANNEL_ORDERS,
            |order| { ::bondgraph::ModulatingFunction::new(order, 2, window, step) },
        )?;
        Self::with_bank(params, bank)
    }
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl<D: ::bondgraph::Differentiator> ResidualGenerator<::bondgraph::Each<D, CHANNELS>> {
    /// A generator with the estimator `estimator(order)` for each of the bank's
    /// signals (`order` from [`CHANNEL_ORDERS`]): a
    /// [`StateVariableFilter`](::bondgraph::StateVariableFilter) per signal, say.
    /// Every estimator should have the same delay.
    pub fn with_estimators(
        params: Params,
        estimator: impl FnMut(u32) -> Result<D, ::bondgraph::EstimatorError>,
    ) -> Result<Self, ::bondgraph::EstimatorError> {
        let bank = ::bondgraph::Each::new(CHANNEL_ORDERS, estimator)?;
        Self::with_bank(params, bank)
    }
}
