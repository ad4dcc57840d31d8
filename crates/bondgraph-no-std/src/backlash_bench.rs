// Residual code for the model `backlash_bench` (models/backlash_bench.bg), written by bgc.
// It needs the `bondgraph` runtime crate.

#[allow(unused_imports)]
use ::bondgraph::Real as _;
/// The model's parameters; [`Default`] gives the values the model declares.
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub struct Params {
    /// `Re` [Ohm]: armature resistance (model value 0.3)
    pub Re: f64,
    /// `L` [H]: armature inductance (model value 0.5)
    pub L: f64,
    /// `ke` [N.m/A]: torque (and back-emf) constant (model value 0.5)
    pub ke: f64,
    /// `Je` [kg.m^2]: motor-side inertia (model value 0.8)
    pub Je: f64,
    /// `fe` [N.m.s/rad]: motor-side viscous friction (model value 0.1)
    pub fe: f64,
    /// `K` [N.m/rad]: link stiffness (model value 1)
    pub K: f64,
    /// `N`: reduction ratio: theta_e' = N theta_s' (model value 5)
    pub N: f64,
    /// `Js` [kg.m^2]: load inertia (model value 10)
    pub Js: f64,
    /// `fs` [N.m.s/rad]: load viscous friction (model value 8)
    pub fs: f64,
    /// `j0` [rad]: dead-zone half width (model value 0.2)
    pub j0: f64,
    /// `gamma` [1/rad]: slope of the dead-zone sigmoid (model value 2.5)
    pub gamma: f64,
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Default for Params {
    fn default() -> Self {
        Params {
            Re: 0.3,
            L: 0.5,
            ke: 0.5,
            Je: 0.8,
            fe: 0.1,
            K: 1.0,
            N: 5.0,
            Js: 10.0,
            fs: 8.0,
            j0: 0.2,
            gamma: 2.5,
        }
    }
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Params {
    /// How far each parameter's true value may be from the model's (`+- 5%` in the
    /// model), as a half-width in its unit; 0 for those it states exactly.
    pub const UNCERTAINTY: Params = Params {
        Re: 0.015,
        L: 0.025,
        ke: 0.0,
        Je: 0.04,
        fe: 0.005,
        K: 0.0,
        N: 0.0,
        Js: 0.5,
        fs: 0.4,
        j0: 0.0,
        gamma: 0.0,
    };
    /// The fields' names, in order.
    pub const NAMES: [&'static str; 11] = [
        "Re",
        "L",
        "ke",
        "Je",
        "fe",
        "K",
        "N",
        "Js",
        "fs",
        "j0",
        "gamma",
    ];
    /// The fields from an array in the order of [`Params::NAMES`].
    #[must_use]
    #[allow(non_snake_case)]
    pub fn from_array(a: [f64; 11]) -> Self {
        let [Re, L, ke, Je, fe, K, N, Js, fs, j0, gamma] = a;
        Params {
            Re,
            L,
            ke,
            Je,
            fe,
            K,
            N,
            Js,
            fs,
            j0,
            gamma,
        }
    }
    /// The fields as an array in the order of [`Params::NAMES`].
    #[must_use]
    pub fn to_array(&self) -> [f64; 11] {
        [
            self.Re,
            self.L,
            self.ke,
            self.Je,
            self.fe,
            self.K,
            self.N,
            self.Js,
            self.fs,
            self.j0,
            self.gamma,
        ]
    }
}
/// What the residuals read: the inputs and measured signals, their time derivatives
/// (`NAME_d1`, `NAME_d2`…) and integrals from the start of the record (`NAME_int`).
#[allow(non_snake_case)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub struct Signals {
    /// The integral of `U0` from the start of the record.
    pub U0_int: f64,
    /// The measured signal `y1`.
    pub y1: f64,
    /// The time derivative of order 1 of `y1`.
    pub y1_d1: f64,
    /// The integral of `y1` from the start of the record.
    pub y1_int: f64,
    /// The measured signal `y2`.
    pub y2: f64,
    /// The time derivative of order 1 of `y2`.
    pub y2_d1: f64,
    /// The integral of `y2` from the start of the record.
    pub y2_int: f64,
    /// `int(-(Re * y2 * fs / N / ke))`: the integral from the start of the record of an expression that is not linear in the signals.
    pub int1: f64,
    /// `int((N * y2 - y1) * (exp(gamma * (N * int(y2) - int(y1))) * j0 * gamma * 8 / (exp(gamma * (N * int(y2) - int(y1))) + 1) ^ 2 - 1))`: the integral from the start of the record of an expression that is not linear in the signals.
    pub int2: f64,
}
#[allow(dead_code, unreachable_pub, clippy::all)]
impl Signals {
    /// The fields' names, in order.
    pub const NAMES: [&'static str; 9] = [
        "U0_int",
        "y1",
        "y1_d1",
        "y1_int",
        "y2",
        "y2_d1",
        "y2_int",
        "int1",
        "int2",
    ];
    /// The fields from an array in the order of [`Signals::NAMES`].
    #[must_use]
    #[allow(non_snake_case)]
    pub fn from_array(a: [f64; 9]) -> Self {
        let [U0_int, y1, y1_d1, y1_int, y2, y2_d1, y2_int, int1, int2] = a;
        Signals {
            U0_int,
            y1,
            y1_d1,
            y1_int,
            y2,
            y2_d1,
            y2_int,
            int1,
            int2,
        }
    }
    /// The fields as an array in the order of [`Signals::NAMES`].
    #[must_use]
    pub fn to_array(&self) -> [f64; 9] {
        [
            self.U0_int,
            self.y1,
            self.y1_d1,
            self.y1_int,
            self.y2,
            self.y2_d1,
            self.y2_int,
            self.int1,
            self.int2,
        ]
    }
}
/// How many residuals [`residuals`] returns: one per ARR.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RESIDUAL_COUNT: usize = 2;
/// The ARRs' names, in the order of [`residuals`].
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RESIDUALS: [&str; 2] = ["ARR1", "ARR2"];
/// Whether each residual is simulated: it compares a measured signal with a copy of
/// the model run on the recorded inputs from rest, so it holds on a record that
/// starts with the machine at rest.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const SIMULATED: [bool; 2] = [false, false];
/// Whether each residual is realised by integration: the ARR `r = A + dF/dt` is
/// evaluated as the running value `F + ∫A` (what [`residuals`] returns for it), whose
/// change since a reference instant ([`bondgraph::Reference`]) is the residual
/// `∫ r dt`: it reads each derivative one order lower than the relation.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const INTEGRATED: [bool; 2] = [true, true];
/// Every ARR's residual, in the order of [`RESIDUALS`]; each is zero (up to the
/// estimation of the signals) while the machine is healthy. For a residual realised
/// by integration ([`INTEGRATED`]) it is the running value `F + ∫A`, whose change
/// since a reference instant is zero while the machine is healthy.
///
/// - ARR1: $$U_{0} - y_{1} \, \left(\mathrm{ke} + \mathrm{Re} \, \frac{\mathrm{fe}}{\mathrm{ke}}\right) - \frac{\frac{\mathrm{Re} \, \left(y_{2} \, \mathrm{fs} + \mathrm{Js} \, \dot{y}_{2}\right) + L \, \left(\mathrm{Js} \, \ddot{y}_{2} + \mathrm{fs} \, \dot{y}_{2}\right)}{N} + \mathrm{Re} \, \mathrm{Je} \, \dot{y}_{1} + L \, \left(\mathrm{Je} \, \ddot{y}_{1} + \mathrm{fe} \, \dot{y}_{1}\right)}{\mathrm{ke}} = 0$$; integrated: the running value is $$-\frac{\frac{\mathrm{Re} \, \mathrm{Js} \, y_{2} + L \, \left(\mathrm{Js} \, \dot{y}_{2} + \mathrm{fs} \, y_{2}\right)}{N} + \mathrm{Re} \, \mathrm{Je} \, y_{1} + L \, \left(\mathrm{Je} \, \dot{y}_{1} + \mathrm{fe} \, y_{1}\right)}{\mathrm{ke}} + \int_0^t U_{0} \, d\tau - \left(\mathrm{ke} + \mathrm{Re} \, \frac{\mathrm{fe}}{\mathrm{ke}}\right) \, \int_0^t y_{1} \, d\tau + \int_0^t -\frac{\frac{\mathrm{Re} \, y_{2} \, \mathrm{fs}}{N}}{\mathrm{ke}} \, d\tau$$
/// - ARR2: $$\left(N \, y_{2} - y_{1}\right) \, \left(\exp\left(\gamma \, \left(N \, \int_0^t y_{2} \, d\tau - \int_0^t y_{1} \, d\tau\right)\right) \, \frac{j_{0} \, \gamma \, 8}{{\left(\exp\left(\gamma \, \left(N \, \int_0^t y_{2} \, d\tau - \int_0^t y_{1} \, d\tau\right)\right) + 1\right)}^{2}} - 1\right) - \frac{\mathrm{Js} \, \ddot{y}_{2} + \mathrm{fs} \, \dot{y}_{2}}{N \, K} = 0$$; integrated: the running value is $$-\frac{\mathrm{Js} \, \dot{y}_{2} + \mathrm{fs} \, y_{2}}{N \, K} + \int_0^t \left(N \, y_{2} - y_{1}\right) \, \left(\exp\left(\gamma \, \left(N \, \int_0^t y_{2} \, d\tau - \int_0^t y_{1} \, d\tau\right)\right) \, \frac{j_{0} \, \gamma \, 8}{{\left(\exp\left(\gamma \, \left(N \, \int_0^t y_{2} \, d\tau - \int_0^t y_{1} \, d\tau\right)\right) + 1\right)}^{2}} - 1\right) \, d\tau$$
#[allow(non_snake_case, unused_variables, clippy::all)]
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn residuals(p: &Params, s: &Signals) -> [f64; 2] {
    let t1 = p.Js * s.y2_d1 + p.fs * s.y2;
    [
        -(((p.Re * p.Js * s.y2 + p.L * t1) / p.N + p.Re * p.Je * s.y1
            + p.L * (p.Je * s.y1_d1 + p.fe * s.y1)) / p.ke) + s.U0_int
            - (p.ke + p.Re * p.fe / p.ke) * s.y1_int + s.int1,
        -(t1 / (p.N * p.K)) + s.int2,
    ]
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
pub fn bounds(p: &Params, u: &Params, s: &Signals) -> [f64; 2] {
    [0.0, 0.0]
}
/// The fault signature matrix: which residuals a fault of each component moves.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const FSM: ::bondgraph::Fsm = ::bondgraph::Fsm {
    residuals: &RESIDUALS,
    components: &[
        ::bondgraph::Component {
            name: "U",
            kind: "Se",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Rm",
            kind: "R",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Lm",
            kind: "I",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "motor",
            kind: "GY",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Jm",
            kind: "I",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "fm",
            kind: "R",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Wm",
            kind: "MSe",
            signature: ::bondgraph::Signature::new(2, &[0]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "link",
            kind: "C",
            signature: ::bondgraph::Signature::new(2, &[1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "gear",
            kind: "TF",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Jl",
            kind: "I",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "fl",
            kind: "R",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "Wl",
            kind: "MSe",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "w",
            kind: "let",
            signature: ::bondgraph::Signature::new(2, &[1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "y1",
            kind: "Df",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
        ::bondgraph::Component {
            name: "y2",
            kind: "Df",
            signature: ::bondgraph::Signature::new(2, &[0, 1]),
            detectable: true,
            isolable: false,
        },
    ],
};
/// The components whose fault explains the residuals in alarm (see
/// [`bondgraph::Fsm::candidates`]).
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn candidates(alarms: &[bool; 2]) -> ::bondgraph::Vec<&'static str> {
    FSM.candidates(alarms)
}
/// The components whose fault is consistent with the residuals in alarm, with no
/// exoneration (see [`bondgraph::Fsm::suspects`]).
#[must_use]
#[allow(dead_code, unreachable_pub, clippy::all)]
pub fn suspects(alarms: &[bool; 2]) -> ::bondgraph::Vec<&'static str> {
    FSM.suspects(alarms)
}
/// The raw signals [`ResidualGenerator::push`] takes, in order: the inputs and
/// measured signals the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RAW_SIGNALS: [&str; 3] = ["U0", "y1", "y2"];
/// The highest derivative of each raw signal the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const RAW_ORDERS: [u32; 3] = [0, 1, 1];
/// How many signals the generator's estimator bank takes: the raw signals whose
/// derivatives the ARRs read, the other raw signals, then the trapezoidal integrals of
/// those whose integral the ARRs read.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const CHANNELS: usize = 6;
/// How many of the bank's first [`CHANNELS`] need derivatives.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const DIFFERENTIATED: usize = 2;
/// The highest derivative the ARRs read of each of the bank's [`CHANNELS`] signals.
#[allow(dead_code, unreachable_pub, clippy::all)]
pub const CHANNEL_ORDERS: [u32; CHANNELS] = [1, 1, 0, 0, 0, 0];
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
    integrals: [::bondgraph::Trapezoid; 3],
    others: [::bondgraph::Trapezoid; 2],
    references: [::bondgraph::Reference; 2],
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
            integrals: [::bondgraph::Trapezoid::new(); 3],
            others: [::bondgraph::Trapezoid::new(); 2],
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
    pub fn push(&mut self, t: f64, raw: [f64; 3]) -> Option<[f64; RESIDUAL_COUNT]> {
        let mut x = [0.0; CHANNELS];
        x[0] = raw[1];
        x[1] = raw[2];
        x[2] = raw[0];
        x[3] = self.integrals[0].push(t, raw[0]);
        x[4] = self.integrals[1].push(t, raw[1]);
        x[5] = self.integrals[2].push(t, raw[2]);
        let at = t - self.bank.delay();
        let [e0, e1, ..] = self.bank.push(x)? else {
            return None;
        };
        let p = &self.params;
        let mut s = Signals::default();
        s.U0_int = e0[3];
        s.y1 = e0[0];
        s.y1_d1 = e1[0];
        s.y1_int = e0[4];
        s.y2 = e0[1];
        s.y2_d1 = e1[1];
        s.y2_int = e0[5];
        s.int1 = self.others[0].push(at, -(p.Re * s.y2 * p.fs / p.N / p.ke));
        s.int2 = {
            let e1 = (p.gamma * (p.N * s.y2_int - s.y1_int)).exp();
            self.others[1]
                .push(
                    at,
                    (p.N * s.y2 - s.y1)
                        * (e1 * p.j0 * p.gamma * 8.0 / (e1 + 1.0).powi(2) - 1.0),
                )
        };
        let mut r = residuals(p, &s);
        r[0] = self.references[0].push(r[0]);
        r[1] = self.references[1].push(r[1]);
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
        let Ok(raw) = <[f64; 3]>::try_from(raw) else {
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
