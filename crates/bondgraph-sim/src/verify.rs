//! `bgc verify`: what bgc derived, checked numerically on the model's own trajectories.
//!
//! The plant is simulated from the product's state equations (classic RK4, fixed step) from
//! several initial states, with smooth inputs whose derivatives are known exactly. Each
//! measured signal and every time derivative an ARR reads is computed exactly, by
//! differentiating the outputs symbolically along the state equations; every `int(..)` is
//! integrated with the plant (so ARRs assume zero initial values of their integrals, as the
//! plant starts them). The unknown of a nonlinear algebraic loop is solved by Newton's method
//! wherever the plant is evaluated, and differentiated implicitly from its equation
//! `R(x, u, v) = 0`: `dv/dt = −(dR/dt, v held) / (∂R/∂v)`. Then:
//! - every residual must stay at round-off level on the healthy plant, relative to the size
//!   of its terms along the run;
//! - every FSM entry is checked by a fault in the plant only: each parameter of a component
//!   at +20 % (a sensor: a smooth additive fault of a fifth of its peak on its measurement; a
//!   source applying an input of its own: the same on the input as the plant receives it);
//!   the residuals the FSM marks must move, the others must not. A component that none of
//!   these can fault (a source driven by a modulation) is listed as not checked. A residual
//!   has moved when it passes 1e-6 of its terms, or 10⁴ times what the healthy plant left of
//!   it (and 1e-12 of its terms): a relation of high order moves by a small share of its
//!   large terms, far above its round-off, and a dependence the equations do not have
//!   leaves it at round-off.
//!
//! What is checked is exactly what the emitters print: the product's expressions. A residual
//! realised by integration (`r = A + dF/dt`, evaluated as `F + ∫A` less its value at a
//! reference) is checked as `A + dF/dt` with `dF/dt` taken exactly along the plant: the split
//! is what the generator relies on, and the error of integrating numerically is not bgc's.

use std::collections::{BTreeSet, HashMap};

use bondgraph_core::{
    Auxiliary, Mode, Realisation, ResidualForm, Sensor, StorageCausality, Symbol,
};
use bondgraph_core::{BinOp, Func};
use bondgraph_core::{Compiled, Component, ComponentKind, Handle, Input, Parameter, State};
use bondgraph_core::{Derivatives, ExprId, Node, Pool, Tape};

/// How the check is run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VerifyOptions {
    /// Amplitude of the inputs: `u_k(t) = scale (1 + 0.5 sin(w_k t + k))`.
    pub input_scale: f64,
    /// Typical size of the initial states.
    pub state_scale: f64,
    /// Initial states tried.
    pub runs: usize,
    /// RK4 steps per run.
    pub steps: usize,
    /// The step, in seconds.
    pub step: f64,
    /// Largest relative |residual| accepted on the healthy plant.
    pub healthy: f64,
    /// Smallest relative |residual| that counts as "moved" under a fault.
    pub moved: f64,
    /// A fault also moves a residual when it takes it this many times above the largest
    /// relative |residual| of the healthy plant, and above [`VerifyOptions::floor`]: a
    /// relation of high order, whose terms are large, moves by a small share of them, yet
    /// far above its own round-off.
    pub above_healthy: f64,
    /// The relative |residual| below which nothing counts as moved.
    pub floor: f64,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        VerifyOptions {
            input_scale: 1.0,
            state_scale: 0.5,
            runs: 3,
            steps: 1500,
            step: 1e-3,
            healthy: 1e-8,
            moved: 1e-6,
            above_healthy: 1e4,
            floor: 1e-12,
        }
    }
}

impl VerifyOptions {
    /// Most RK4 steps of one run, and most runs: a check of a relation needs a few thousand
    /// steps, and a count past these bounds is a typo that would run for hours.
    pub const MAX_STEPS: usize = 1_000_000;
    /// See [`VerifyOptions::MAX_STEPS`].
    pub const MAX_RUNS: usize = 1_000;
    /// Largest input or state scale: past it, the model's terms overflow a double and every
    /// relation would fail for the arithmetic, not for the model.
    pub const MAX_SCALE: f64 = 1e12;

    /// Whether the options can verify anything, else what is wrong with the first that
    /// cannot (in the CLI's and Python's words alike: `steps`, `input scale`…).
    pub fn check(&self) -> Result<(), String> {
        let scale = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 && v <= Self::MAX_SCALE {
                Ok(())
            } else {
                Err(format!(
                    "{name} must be a number in (0, {:e}], not {v}",
                    Self::MAX_SCALE
                ))
            }
        };
        scale("input scale", self.input_scale)?;
        scale("state scale", self.state_scale)?;
        if !(1..=Self::MAX_STEPS).contains(&self.steps) {
            return Err(format!(
                "steps must be 1 to {}, not {}",
                Self::MAX_STEPS,
                self.steps
            ));
        }
        if !(1..=Self::MAX_RUNS).contains(&self.runs) {
            return Err(format!(
                "runs must be 1 to {}, not {}",
                Self::MAX_RUNS,
                self.runs
            ));
        }
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(format!(
                "step must be a finite number of seconds > 0, not {}",
                self.step
            ));
        }
        Ok(())
    }
}

/// Why a model cannot be verified at all.
#[derive(Clone, Debug, PartialEq)]
pub enum VerifyError {
    /// The state equations were not derived, so there is no plant to simulate.
    NoStateEquations,
    /// There is nothing to check.
    NoArrs,
    /// The state equations hold nonlinear algebraic loops whose unknowns set each other (the
    /// unknowns named): verification differentiates the outputs along the state equations,
    /// and each loop's unknown implicitly from its own equation only.
    ImplicitLoops(Vec<String>),
    /// The simulation left the finite numbers (at this time, in seconds).
    Diverged(f64),
    /// Every scale and step tried left the finite numbers: the last try's time (s), and the
    /// smallest state scale and step tried.
    NoFiniteRun {
        /// When the last try left the finite numbers, in seconds.
        at: f64,
        /// The smallest scale of the initial states tried.
        state_scale: f64,
        /// The shortest step tried, in seconds.
        step: f64,
    },
}

impl std::fmt::Display for VerifyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            VerifyError::NoStateEquations => f.write_str(
                "the state equations could not be derived, so the model cannot be simulated",
            ),
            VerifyError::NoArrs => f.write_str("the model has no ARRs to verify"),
            VerifyError::ImplicitLoops(names) => write!(
                f,
                "the state equations hold nonlinear algebraic loops whose unknowns {} set each other: \
                 verify differentiates each unknown implicitly from its own equation only; \
                 check the ARRs on simulated data with `bgc simulate` and `bgc residuals` instead",
                names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
            ),
            VerifyError::Diverged(t) => write!(f, "the simulation left the finite numbers at t = {t} s"),
            VerifyError::NoFiniteRun { at, state_scale, step } => write!(
                f,
                "every run left the finite numbers (the last at t = {at} s), with initial states \
                 down to a scale of {state_scale:e} and steps down to {step:e} s: give \
                 --state-scale the size of the model's states in its own units (a pressure in Pa \
                 is 1e5, a volume in m^3 1e-3), and --input-scale that of its inputs"
            ),
        }
    }
}

/// One ARR on the healthy plant.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrCheck {
    /// Its name.
    pub name: String,
    /// Largest relative |residual| over all runs.
    pub worst: f64,
    /// Realised by integration: the largest jump of its level across a zero crossing of a
    /// `sign`, `abs`, `min` or `max` argument, beyond what its rate accounts for, relative
    /// to the level's largest size (`None` when no run crossed one, or the ARR is evaluated
    /// as written).
    pub jump: Option<f64>,
    /// Whether it stayed under the tolerance, and its level did across every crossing.
    pub pass: bool,
}

/// The zero crossings of the arguments where `sign`, `abs`, `min` and `max` switch, which
/// the runs went through.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ZeroCrossings {
    /// Arguments of `sign` and `abs`, and differences of `min`'s and `max`'s, that the
    /// state equations and the residuals hold.
    pub arguments: usize,
    /// Crossings the check went through, over every run.
    pub crossed: usize,
    /// Runs with inputs of mean zero added to reverse the model's flows (one per initial
    /// state; none when the model switches nowhere).
    pub reversing_runs: usize,
    /// Walks stopped where the model left the finite numbers (inputs of mean zero may take
    /// it out of its domain); what they crossed before is kept.
    pub stopped: usize,
}

/// One FSM entry under a fault of its component.
#[derive(Clone, Debug, PartialEq)]
pub struct EntryCheck {
    /// The component.
    pub component: Handle<Component>,
    /// The ARR (position in [`Compiled::arrs`]).
    pub arr: usize,
    /// What the FSM says: the ARR is sensitive to the component.
    pub marked: bool,
    /// Largest relative |residual| under the fault.
    pub worst: f64,
    /// Whether the ARR behaved as the FSM says.
    pub pass: bool,
}

/// The outcome of [`verify`].
#[derive(Clone, Debug, PartialEq)]
pub struct Verification {
    /// Each ARR on the healthy plant.
    pub arrs: Vec<ArrCheck>,
    /// Each FSM entry of each component that can be faulted in the plant.
    pub entries: Vec<EntryCheck>,
    /// Components that cannot be faulted from the product (a source without parameters of
    /// its own): their entries are not checked.
    pub unchecked: Vec<Handle<Component>>,
    /// The RK4 step used: the one asked for, or a tenth of it for each time the simulation
    /// of a stiff model left the finite numbers.
    pub step: f64,
    /// The scale of the initial states: the one asked for, or a tenth of it for each time
    /// every step tried left the finite numbers.
    pub state_scale: f64,
    /// How many times the initial states were shrunk tenfold to get there.
    pub scalings: u32,
    /// The zero crossings the integrated residuals were checked across.
    pub crossings: ZeroCrossings,
}

impl Verification {
    /// Whether every check passed.
    pub fn passed(&self) -> bool {
        self.arrs.iter().all(|a| a.pass) && self.entries.iter().all(|e| e.pass)
    }
}

/// A leaf of the verification pool: the plant's parameters and the detector's nominal ones
/// are different leaves, so that a fault changes the plant only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum V {
    Plant(Handle<Parameter>),
    Nominal(Handle<Parameter>),
    Input(Handle<Input>, u32),
    State(Handle<State>),
    /// A state of the copy of the model that simulated residuals run: nominal parameters,
    /// inputs as commanded.
    Estimate(Handle<State>),
    /// The n-th derivative of the additive fault on a sensor.
    SensorFault(Handle<Sensor>, u32),
    /// The n-th derivative of the additive fault on an input as the plant receives it (an
    /// actuator fault): the ARRs read the input as commanded.
    InputFault(Handle<Input>, u32),
    Time,
    /// An unknown of a nonlinear algebraic loop of the plant, solved by Newton's method
    /// wherever the plant is evaluated.
    Loop(Handle<bondgraph_core::LoopUnknown>),
    /// A root an ARR reads, solved by Newton's method wherever the residuals are evaluated.
    Root(Handle<bondgraph_core::Root>),
}

type VId = ExprId<V>;

/// What an expression imported into the plant's pool stands for.
#[derive(Clone, Copy)]
enum Root {
    /// An auxiliary signal's derivative.
    Auxiliary(Handle<Auxiliary>, u32),
    /// A root's law.
    Law,
    /// A root's n-th derivative (n ≥ 1), in terms of the roots.
    Derivative(Handle<bondgraph_core::Root>, u32),
    /// A residual evaluated as written.
    Residual,
    /// The level of an integrated residual; its rate comes next.
    Level,
    /// The rate of an integrated residual.
    Rate,
}

/// The plant and the residuals over its states, in one pool.
struct Plant {
    /// The plant's right-hand sides, then those of the copy simulated residuals run (none
    /// when no residual is simulated).
    rhs: Vec<VId>,
    /// How many states the plant has.
    states: usize,
    /// For each state of the copy, the plant's state it starts from: its own, or for a
    /// partial copy's the model's state of the same name.
    starts: Vec<usize>,
    /// Each detector's output, to size the faults put on it.
    outputs: Vec<(Handle<Sensor>, VId)>,
    integrals: Vec<VId>,
    residuals: Vec<VId>,
    terms: Vec<Vec<VId>>,
    /// The right-hand sides, then each integral's argument.
    derivative_tape: Tape<V>,
    /// The residuals, then the terms of each in turn.
    residual_tape: Tape<V>,
    /// The detectors' outputs.
    output_tape: Tape<V>,
    /// The equations `residual = 0` that set the loops' unknowns, one each.
    loop_tape: Tape<V>,
    /// How many loop unknowns there are.
    loops: usize,
    /// The laws of the roots the ARRs read, `g = 0` at each root.
    root_tape: Tape<V>,
    /// How many roots there are.
    roots: usize,
    /// Where `sign`, `abs`, `min` and `max` switch (the arguments of the first two, the
    /// differences of the others' two), then each integrated residual's level, then its
    /// rate, in the order of [`Plant::integrated`].
    crossing_tape: Tape<V>,
    /// How many switching arguments the crossing tape starts with.
    switches: usize,
    /// The residuals realised by integration (positions in [`Plant::residuals`]).
    integrated: Vec<usize>,
}

/// Most zero crossings checked per run: a friction that sticks chatters through zero at every
/// step, and a few hundred crossings show a jump as well as thousands.
const MOST_CROSSINGS_PER_RUN: usize = 200;
/// Half the interval around a zero crossing over which an integrated level's jump is
/// measured, as a share of the step.
const CROSSING_HALF_WIDTH: f64 = 1e-7;

/// What the walks through zero crossings found, over all runs.
#[derive(Clone, Debug, Default)]
struct Crossings {
    /// Crossings checked.
    crossed: usize,
    /// Each integrated residual's largest jump of its level across a crossing.
    jumps: Vec<f64>,
    /// Each integrated residual's largest |level| met, to judge its jumps against.
    levels: Vec<f64>,
    /// Walks stopped where a value left the finite numbers.
    stopped: usize,
}

impl Crossings {
    fn new(integrated: usize) -> Self {
        Crossings {
            jumps: vec![0.0; integrated],
            levels: vec![0.0; integrated],
            ..Crossings::default()
        }
    }

    /// Keeps the largest |level| of `values`, the crossing tape's, whose levels start after
    /// the `switches` arguments.
    fn sizes(&mut self, switches: usize, values: &[f64]) {
        for (j, size) in self.levels.iter_mut().enumerate() {
            *size = size.max(values[switches + j].abs());
        }
    }

    /// Each integrated residual's largest jump relative to its level's size.
    fn relative(&self) -> Vec<f64> {
        (self.jumps.iter().zip(&self.levels))
            .map(|(&j, &l)| {
                if j == 0.0 {
                    0.0
                } else {
                    j / l.max(f64::MIN_POSITIVE)
                }
            })
            .collect()
    }
}

/// Most times the step is divided by ten for a stiff model.
const MAX_REFINEMENTS: usize = 3;
/// How many times the initial states may shrink tenfold: from the default 0.5 down to 5e-7,
/// half a millilitre in m^3.
const MAX_SCALINGS: usize = 6;

/// How far [`verify_reporting`] is: components whose faults were simulated, of all, at the
/// initial-state scale being tried (a run that leaves the finite numbers starts again smaller).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Components done.
    pub components: usize,
    /// Components in all.
    pub of: usize,
    /// The initial-state scale of this attempt.
    pub scale: f64,
}

/// Checks every ARR and FSM entry of `c` numerically.
pub fn verify(c: &Compiled, options: &VerifyOptions) -> Result<Verification, VerifyError> {
    verify_reporting(c, options, &mut |_| {})
}

/// [`verify`], telling `progress` how far it is after each component's faults (one
/// simulation per fault, the slow part on a large model).
pub fn verify_reporting(
    c: &Compiled,
    options: &VerifyOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Verification, VerifyError> {
    let space = c
        .state_space
        .as_ref()
        .ok_or(VerifyError::NoStateEquations)?;
    if c.arrs.is_empty() {
        return Err(VerifyError::NoArrs);
    }
    let plant = plant(c, space).ok_or_else(|| {
        VerifyError::ImplicitLoops(space.loops.iter().map(|l| l.name.clone()).collect())
    })?;
    // The scale that suits a model is found, not asked for: the initial states shrink
    // tenfold while the run leaves the finite numbers, and at each scale the step shrinks
    // tenfold while it leaves them after the start (a stiff model). Leaving them on the
    // first step means the start is outside the model's domain (a liquid volume past its
    // accumulator's gas volume), which no step cures.
    let mut last = 0.0;
    let mut tried = *options;
    for smaller in 0..=MAX_SCALINGS {
        let mut attempt = *options;
        attempt.state_scale = options.state_scale / 10f64.powi(smaller as i32);
        for _ in 0..=MAX_REFINEMENTS {
            tried = attempt;
            match verify_with(c, &plant, &attempt, progress) {
                Ok(mut v) => {
                    v.scalings = smaller as u32;
                    return Ok(v);
                }
                Err(VerifyError::Diverged(t)) => {
                    last = t;
                    if t == 0.0 {
                        break;
                    }
                    attempt.step /= 10.0;
                }
                Err(other) => return Err(other),
            }
        }
    }
    Err(VerifyError::NoFiniteRun {
        at: last,
        state_scale: tried.state_scale,
        step: options.step / 10f64.powi(MAX_REFINEMENTS as i32),
    })
}

fn verify_with(
    c: &Compiled,
    plant: &Plant,
    options: &VerifyOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Verification, VerifyError> {
    let nominal: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let n = plant.states;
    let held = held_in_diagnosis(c);
    let initial: Vec<Vec<f64>> = (0..options.runs.max(1))
        .map(|seed| {
            (0..n)
                .map(|i| match held.get(i) {
                    Some(true) => 0.0,
                    _ => options.state_scale * (0.4 + 0.37 * ((i * 7 + seed * 3) % 5) as f64),
                })
                .collect()
        })
        .collect();
    let healthy_run = Run {
        plant,
        plant_params: nominal.clone(),
        nominal: nominal.clone(),
        faulty_sensor: None,
        faulty_input: None,
        fault_size: 0.0,
        options,
        inputs: Inputs::Offset,
        guess: std::cell::RefCell::new(vec![0.0; plant.loops]),
        root_guess: std::cell::RefCell::new(vec![0.0; plant.roots]),
    };
    // A sensor fault is a fifth of the signal's peak on the healthy plant: a fixed size would
    // be lost in a pressure of megapascals and swamp a temperature of a few kelvin.
    let peaks = healthy_run.peaks(&initial[0])?;
    let mut worst = vec![0.0f64; c.arrs.len()];
    for x0 in &initial {
        for (w, r) in worst.iter_mut().zip(healthy_run.worst(x0)?) {
            *w = w.max(r);
        }
    }
    let healthy_worst = worst.clone();
    let gaps = split_gaps(c);
    let (crossings, jumps) = through_crossings(&healthy_run, &initial);
    let arrs = c
        .arrs
        .iter()
        .zip(&worst)
        .zip(&gaps)
        .zip(jumps)
        .map(|(((a, &w), &gap), jump)| {
            let w = w.max(gap);
            ArrCheck {
                name: a.name.clone(),
                worst: w,
                jump,
                pass: w < options.healthy && jump.is_none_or(|j| j < options.healthy),
            }
        })
        .collect();
    let mut entries = Vec::new();
    let mut unchecked = Vec::new();
    let total = c.components.len();
    for (done, (h, comp)) in c.components.iter().enumerate() {
        progress(Progress {
            components: done,
            of: total,
            scale: options.state_scale,
        });
        // Each fault, with the ARRs it may move besides the component's own: a parameter
        // shared by several components is a fault of all of them.
        let faults: Vec<(Run<'_>, BTreeSet<usize>)> = match comp.kind {
            ComponentKind::Sensor(_) => c
                .sensors
                .find(|s| s.name == comp.name)
                .map(|s| {
                    let peak = plant
                        .outputs
                        .iter()
                        .position(|(o, _)| *o == s)
                        .map_or(0.0, |i| peaks[i]);
                    let run = Run {
                        faulty_sensor: Some(s),
                        fault_size: if peak > 0.0 { 0.2 * peak } else { 1.0 },
                        ..healthy_run.clone()
                    };
                    (run, BTreeSet::new())
                })
                .into_iter()
                .collect(),
            ComponentKind::Element(_) if comp.parameters.is_empty() => {
                actuator(c, comp)
                    .map(|u| {
                        let run = Run {
                            faulty_input: Some(u),
                            // A fifth of the inputs' peak, 1.5 times their amplitude.
                            fault_size: 0.3 * options.input_scale,
                            ..healthy_run.clone()
                        };
                        (run, BTreeSet::new())
                    })
                    .into_iter()
                    .collect()
            }
            _ => comp
                .parameters
                .iter()
                .map(|p| {
                    let mut faulty = nominal.clone();
                    faulty[p.index()] *= 1.2;
                    let run = Run {
                        plant_params: faulty,
                        ..healthy_run.clone()
                    };
                    (run, shared_marks(c, h, *p))
                })
                .collect(),
        };
        if faults.is_empty() {
            unchecked.push(h);
            continue;
        }
        let marks: BTreeSet<usize> = comp.marks.iter().copied().collect();
        let mut moved = vec![0.0f64; c.arrs.len()];
        let mut stray = vec![0.0f64; c.arrs.len()];
        for (run, shared) in &faults {
            for (k, r) in run.worst(&initial[0])?.into_iter().enumerate() {
                moved[k] = moved[k].max(r);
                if !shared.contains(&k) {
                    stray[k] = stray[k].max(r);
                }
            }
        }
        for k in 0..c.arrs.len() {
            let marked = marks.contains(&k);
            let (worst, pass) = if marked {
                let clear =
                    moved[k] > options.floor && moved[k] > options.above_healthy * healthy_worst[k];
                (moved[k], moved[k] > options.moved || clear)
            } else {
                (stray[k], stray[k] < options.healthy)
            };
            entries.push(EntryCheck {
                component: h,
                arr: k,
                marked,
                worst,
                pass,
            });
        }
    }
    Ok(Verification {
        arrs,
        entries,
        unchecked,
        step: options.step,
        state_scale: options.state_scale,
        scalings: 0,
        crossings,
    })
}

/// The healthy runs' walks through the zero crossings of the switching arguments, then those
/// of as many runs with inputs of mean zero, from initial states of alternating signs: the
/// offset inputs of the other runs seldom reverse a speed. Each ARR's relative jump across
/// them, `None` when it is evaluated as written or nothing crossed.
fn through_crossings(healthy: &Run<'_>, initial: &[Vec<f64>]) -> (ZeroCrossings, Vec<Option<f64>>) {
    let plant = healthy.plant;
    let mut jumps = vec![None; plant.residuals.len()];
    if plant.switches == 0 {
        return (ZeroCrossings::default(), jumps);
    }
    let mut found = Crossings::new(plant.integrated.len());
    for x0 in initial {
        healthy.crossings(x0, &mut found);
    }
    let reversing = Run {
        inputs: Inputs::Reversing,
        ..healthy.clone()
    };
    for (seed, x0) in initial.iter().enumerate() {
        let alternating: Vec<f64> = (x0.iter().enumerate())
            .map(|(i, v)| if (i + seed) % 2 == 0 { -v } else { *v })
            .collect();
        reversing.crossings(&alternating, &mut found);
    }
    if found.crossed > 0 {
        for (&k, jump) in plant.integrated.iter().zip(found.relative()) {
            jumps[k] = Some(jump);
        }
    }
    let summary = ZeroCrossings {
        arguments: plant.switches,
        crossed: found.crossed,
        reversing_runs: initial.len(),
        stopped: found.stopped,
    };
    (summary, jumps)
}

/// For each state, the model's state its copy starts from: itself, or for a partial copy's
/// the model's state of the same name.
fn starts(c: &Compiled) -> Vec<usize> {
    let model = c.model_states();
    (c.states.values().enumerate())
        .map(|(k, s)| match s.copy {
            None => k,
            Some(_) => (c.states.values().take(model))
                .position(|m| m.name == s.name)
                .unwrap_or(k),
        })
        .collect()
}

/// The input a source applies, when it applies exactly one that no other component applies:
/// a fault of that actuator is then a fault of the input as the plant receives it.
/// Whether each state's element keeps integral causality in diagnosis: the ARRs then read its
/// state as integrals of signals from the start of the record, so they hold from a start where
/// that state is zero, and the runs start it there.
fn held_in_diagnosis(c: &Compiled) -> Vec<bool> {
    let diagnosis = c.causality.iter().find(|r| r.mode == Mode::Diagnosis);
    let held = |element: &str| {
        diagnosis.is_some_and(|r| {
            (r.storage.iter()).any(|(name, k)| name == element && *k == StorageCausality::Integral)
        })
    };
    // A partial copy's state is none of the plant's: it stays at zero there.
    (c.states.values())
        .map(|s| s.copy.is_some() || held(&s.element))
        .collect()
}

fn actuator(c: &Compiled, comp: &Component) -> Option<Handle<Input>> {
    let [signal] = comp.signals.as_slice() else {
        return None;
    };
    let shared = c
        .components
        .values()
        .filter(|other| other.signals.contains(signal))
        .count();
    (shared == 1)
        .then(|| c.inputs.find(|u| &u.name == signal))
        .flatten()
}

/// Where a change of parameter `p`, which other components than `own` own too, can show:
/// the FSM's `shared parameters` entry for it (their rows, and every ARR that reads it).
fn shared_marks(c: &Compiled, own: Handle<Component>, p: Handle<Parameter>) -> BTreeSet<usize> {
    let others = c
        .components
        .iter()
        .filter(|(h, comp)| *h != own && comp.parameters.contains(&p))
        .flat_map(|(_, comp)| comp.marks.iter().copied());
    let shared = c
        .shared_parameters()
        .into_iter()
        .filter(|s| s.parameter == p);
    others.chain(shared.flat_map(|s| s.marks)).collect()
}

/// The plant and the residuals in one pool; `None` when the state equations hold loops whose
/// unknowns set each other (each loop's equation must hold its own unknown only, for its
/// derivative along the state equations).
fn plant(c: &Compiled, space: &bondgraph_core::StateSpace) -> Option<Plant> {
    let mut pool: Pool<V> = Pool::default();
    let plant_leaf = |p: &mut Pool<V>, s: Symbol| match s {
        Symbol::Parameter(k) => p.leaf(V::Plant(k)),
        Symbol::Input(u, n) => {
            let commanded = p.leaf(V::Input(u, n));
            let fault = p.leaf(V::InputFault(u, n));
            p.add(commanded, fault)
        }
        Symbol::State(k) => p.leaf(V::State(k)),
        // State equations and outputs read no measured signal.
        Symbol::Sensor(..) | Symbol::Auxiliary(..) | Symbol::Time | Symbol::Root(..) => {
            p.leaf(V::Time)
        }
        Symbol::Loop(k) => p.leaf(V::Loop(k)),
    };
    let n = c.states.len();
    let mut rhs = vec![pool.num(0.0); n];
    for (k, e) in &space.equations {
        rhs[k.index()] = pool.import_from(&c.exprs, *e, plant_leaf);
    }
    let mut outputs: HashMap<Handle<Sensor>, VId> = HashMap::new();
    for (s, e) in &space.outputs {
        outputs.insert(*s, pool.import_from(&c.exprs, *e, plant_leaf));
    }
    if c.arrs.iter().any(|a| a.form == ResidualForm::Simulated) {
        // A partial copy reads what a detector measures: the plant's output.
        let copy_leaf = |p: &mut Pool<V>, s: Symbol| match s {
            Symbol::Parameter(k) => p.leaf(V::Nominal(k)),
            Symbol::Input(u, n) => p.leaf(V::Input(u, n)),
            Symbol::State(k) => p.leaf(V::Estimate(k)),
            Symbol::Sensor(s, 0) => match outputs.get(&s) {
                Some(&y) => {
                    let fault = p.leaf(V::SensorFault(s, 0));
                    p.add(y, fault)
                }
                None => p.num(f64::NAN),
            },
            Symbol::Sensor(..) | Symbol::Auxiliary(..) | Symbol::Time => p.leaf(V::Time),
            Symbol::Loop(_) | Symbol::Root(..) => p.num(f64::NAN),
        };
        let mut copy = vec![pool.num(0.0); n];
        let copies = space.copies.iter().flat_map(|k| &k.equations);
        for (k, e) in space.equations.iter().chain(copies) {
            copy[k.index()] = pool.import_from(&c.exprs, *e, copy_leaf);
        }
        rhs.extend(copy);
    }
    let loops: Vec<VId> = (space.loops.iter())
        .map(|l| pool.import_from(&c.exprs, l.residual, plant_leaf))
        .collect();
    let loop_rates = loop_rates(&mut pool, &rhs, &loops)?;
    let mut measured: HashMap<(Handle<Sensor>, u32), VId> = HashMap::new();
    // Auxiliary signals in definition order: each reads earlier ones only.
    let mut auxiliary: HashMap<(Handle<Auxiliary>, u32), VId> = HashMap::new();
    let mut residuals = Vec::new();
    let mut laws = Vec::new();
    let mut root_derivatives: HashMap<(Handle<bondgraph_core::Root>, u32), VId> = HashMap::new();
    let roots = c
        .auxiliaries
        .iter()
        .flat_map(|(a, aux)| {
            (0u32..)
                .zip(&aux.derivatives)
                .map(move |(n, &e)| (Root::Auxiliary(a, n), e))
        })
        .chain(c.roots.values().map(|r| (Root::Law, r.residual)))
        .chain(c.roots.iter().flat_map(|(h, r)| {
            (1u32..)
                .zip(r.derivatives.iter().skip(1))
                .map(move |(n, &e)| (Root::Derivative(h, n), e))
        }))
        .chain(c.arrs.iter().flat_map(|arr| match &arr.realisation {
            Realisation::Direct => vec![(Root::Residual, arr.expr)],
            Realisation::Integrated(i) => vec![(Root::Level, i.level), (Root::Rate, i.rate)],
        }));
    let mut level = None;
    let mut split: Vec<(usize, VId, VId)> = Vec::new();
    for (key, root) in roots {
        let mut signal = |p: &mut Pool<V>, s: Symbol| match s {
            Symbol::Parameter(k) => p.leaf(V::Nominal(k)),
            Symbol::Input(u, n) => p.leaf(V::Input(u, n)),
            Symbol::Sensor(s, n) => {
                let y = output_derivative(p, (&rhs, &loop_rates), &outputs, &mut measured, (s, n));
                let fault = p.leaf(V::SensorFault(s, n));
                p.add(y, fault)
            }
            Symbol::Auxiliary(a, n) => auxiliary
                .get(&(a, n))
                .copied()
                .unwrap_or_else(|| p.num(f64::NAN)),
            // Only a simulated residual reads states: those of its copy of the model.
            Symbol::State(k) => p.leaf(V::Estimate(k)),
            Symbol::Time => p.leaf(V::Time),
            Symbol::Loop(_) => p.num(f64::NAN),
            Symbol::Root(h, 0) => p.leaf(V::Root(h)),
            Symbol::Root(h, n) => {
                (root_derivatives.get(&(h, n)).copied()).unwrap_or_else(|| p.num(f64::NAN))
            }
        };
        let e = pool.import_from(&c.exprs, root, &mut signal);
        match key {
            Root::Auxiliary(a, n) => {
                auxiliary.insert((a, n), e);
            }
            Root::Law => laws.push(e),
            Root::Derivative(h, n) => {
                root_derivatives.insert((h, n), e);
            }
            // `a/b = 0` holds where `a = 0`: its size is judged against a's terms, so that
            // an ARR printed `(…)/k1` is not one term of relative size 1.
            Root::Residual => residuals.push(numerator(&pool, e)),
            Root::Level => level = Some(e),
            // An integrated residual is checked as the generator's integrand: its rate plus
            // its level's derivative along the plant, exactly, so that what is checked is
            // the split itself and not the error of integrating it.
            Root::Rate => {
                let mut along = Derivatives::new(|p: &mut Pool<V>, leaf: V| match leaf {
                    V::Loop(k) => loop_rates.get(k.index()).copied(),
                    V::Root(k) => root_derivatives.get(&(k, 1)).copied(),
                    other => plant_rate(p, &rhs, other),
                });
                let l = level.take();
                let d = l.and_then(|l| along.of(&mut pool, l));
                let d = d.unwrap_or_else(|| pool.num(f64::NAN));
                if let Some(l) = l {
                    split.push((residuals.len(), l, e));
                }
                residuals.push(pool.add(e, d));
            }
        }
    }
    let mut roots = rhs.clone();
    roots.extend(&residuals);
    roots.extend(&loops);
    roots.extend(&laws);
    // A level may hold an integral its derivative does not (`d/dt int(a) = a`).
    roots.extend(split.iter().map(|&(_, level, _)| level));
    let mut integrals = Vec::new();
    pool.visit_reachable(&roots, |id, node| {
        if let Node::Int(_) = node {
            integrals.push(id);
        }
    });
    let terms: Vec<Vec<VId>> = residuals
        .iter()
        .map(|&r| {
            let mut out = Vec::new();
            top_terms(&pool, r, &mut out);
            out
        })
        .collect();
    let mut outputs: Vec<(Handle<Sensor>, VId)> = outputs.into_iter().collect();
    outputs.sort();
    let mut derivative_roots = rhs.clone();
    derivative_roots.extend(integrals.iter().filter_map(|&id| match pool.node(id) {
        Node::Int(arg) => Some(arg),
        _ => None,
    }));
    let mut residual_roots = residuals.clone();
    residual_roots.extend(terms.iter().flatten());
    let output_roots: Vec<VId> = outputs.iter().map(|&(_, e)| e).collect();
    let mut crossing_roots = switches(&mut pool, &roots);
    let switches = crossing_roots.len();
    crossing_roots.extend(split.iter().map(|&(_, level, _)| level));
    crossing_roots.extend(split.iter().map(|&(_, _, rate)| rate));
    Some(Plant {
        crossing_tape: Tape::new(&pool, &crossing_roots),
        switches,
        integrated: split.iter().map(|&(k, _, _)| k).collect(),
        derivative_tape: Tape::new(&pool, &derivative_roots),
        residual_tape: Tape::new(&pool, &residual_roots),
        output_tape: Tape::new(&pool, &output_roots),
        loop_tape: Tape::new(&pool, &loops),
        loops: loops.len(),
        root_tape: Tape::new(&pool, &laws),
        roots: laws.len(),
        rhs,
        states: n,
        starts: starts(c),
        outputs,
        integrals,
        residuals,
        terms,
    })
}

/// Where the non-smooth functions in `roots` switch: the argument of each `sign` and `abs`,
/// and `a − b` for each `min(a, b)` and `max(a, b)`, each once.
fn switches(pool: &mut Pool<V>, roots: &[VId]) -> Vec<VId> {
    let mut found: Vec<(VId, Option<VId>)> = Vec::new();
    pool.visit_reachable(roots, |_, node| match node {
        Node::Call1(Func::Sign | Func::Abs, a) => found.push((a, None)),
        Node::Call2(Func::Min | Func::Max, a, b) => found.push((a, Some(b))),
        _ => {}
    });
    let made: Vec<VId> = (found.into_iter())
        .map(|(a, b)| b.map_or(a, |b| pool.sub(a, b)))
        .collect();
    let mut out: Vec<VId> = (made.into_iter())
        .filter(|&e| !matches!(pool.node(e), Node::Num(_)))
        .collect();
    out.sort();
    out.dedup();
    out
}

/// For each ARR realised by integration, how far `rate + d(level)/dt` is from the relation
/// itself, relative to their size, at a few arbitrary values of every signal, derivative and
/// integral (0 for the others): the split must be an identity, not only hold on the plant's
/// trajectories, for the generator to evaluate the relation that is printed.
fn split_gaps(c: &Compiled) -> Vec<f64> {
    let mut pool = c.exprs.clone();
    let mut d = Derivatives::new(bondgraph_core::time_rate);
    c.arrs
        .iter()
        .map(|arr| {
            let Realisation::Integrated(i) = &arr.realisation else {
                return 0.0;
            };
            let Some(rate) = d.of(&mut pool, i.level).map(|dl| pool.add(i.rate, dl)) else {
                return f64::INFINITY;
            };
            (1..=3)
                .map(|seed| {
                    let at = |e| arbitrary_value(&pool, e, f64::from(seed));
                    let (a, b) = (at(rate), at(arr.expr));
                    let gap = (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
                    if gap.is_nan() {
                        f64::INFINITY
                    } else {
                        gap
                    }
                })
                .fold(0.0, f64::max)
        })
        .collect()
}

/// `e` with each leaf and each `int(..)` given an arbitrary value in [0.5, 1.5), the same
/// for the same leaf or integral whatever expression reads it.
fn arbitrary_value(pool: &Pool<Symbol>, e: ExprId<Symbol>, seed: f64) -> f64 {
    let spread = |x: f64| 0.5 + (x * 0.618_033_988_75 + seed * 0.414_213_562_37).fract();
    let leaf = |s: Symbol| {
        let key = match s {
            Symbol::Parameter(h) => h.index() as f64,
            Symbol::Input(u, n) => 1e3 + 31.0 * u.index() as f64 + f64::from(n),
            Symbol::Sensor(h, n) => 2e3 + 31.0 * h.index() as f64 + f64::from(n),
            Symbol::Auxiliary(a, n) => 3e3 + 31.0 * a.index() as f64 + f64::from(n),
            Symbol::State(k) => 4e3 + k.index() as f64,
            Symbol::Loop(k) => 5e3 + k.index() as f64,
            Symbol::Root(k, n) => 8e3 + 31.0 * k.index() as f64 + f64::from(n),
            Symbol::Time => 6e3,
        };
        spread(key)
    };
    let mut integrals = HashMap::new();
    pool.visit_reachable(&[e], |id, node| {
        if let Node::Int(_) = node {
            integrals.insert(id, spread(7e3 + id.index() as f64));
        }
    });
    bondgraph_core::Evaluator::new(pool, leaf)
        .with_integrals(integrals)
        .value(e)
}

/// Each loop unknown's time derivative along the state equations, from its equation
/// `R(x, u, v) = 0`: `dv/dt = −(∂R/∂t along the plant, v held) / (∂R/∂v)`. `None` when an
/// equation holds another loop's unknown (the loops set each other) or cannot be
/// differentiated.
fn loop_rates(pool: &mut Pool<V>, rhs: &[VId], loops: &[VId]) -> Option<Vec<VId>> {
    let mut rates = Vec::with_capacity(loops.len());
    for (k, &r) in loops.iter().enumerate() {
        let own = |l: &V| matches!(l, V::Loop(j) if j.index() == k);
        if (pool.leaves(r).iter()).any(|l| matches!(l, V::Loop(_)) && !own(l)) {
            return None;
        }
        let mut along = Derivatives::new(|p: &mut Pool<V>, leaf: V| match leaf {
            V::Loop(_) => Some(p.num(0.0)),
            other => plant_rate(p, rhs, other),
        });
        let held = along.of(pool, r)?;
        let mut by_v = Derivatives::partial(|p: &mut Pool<V>, leaf: V| {
            Some(p.num(f64::from(u8::from(own(&leaf)))))
        });
        let slope = by_v.of(pool, r)?;
        let minus = pool.neg(held);
        rates.push(pool.div(minus, slope));
    }
    Some(rates)
}

/// A leaf's time derivative along the plant, loops and the copy's states aside.
fn plant_rate(p: &mut Pool<V>, rhs: &[VId], leaf: V) -> Option<VId> {
    match leaf {
        V::State(k) => Some(rhs[k.index()]),
        V::Input(u, m) => Some(p.leaf(V::Input(u, m + 1))),
        V::SensorFault(s, m) => Some(p.leaf(V::SensorFault(s, m + 1))),
        V::InputFault(u, m) => Some(p.leaf(V::InputFault(u, m + 1))),
        V::Plant(_) | V::Nominal(_) => Some(p.num(0.0)),
        V::Time => Some(p.num(1.0)),
        // Simulated residuals read the copy's states undifferentiated, loops are the
        // caller's, and ARRs read roots undifferentiated: none is differentiated here.
        V::Estimate(_) | V::Loop(_) | V::Root(_) => None,
    }
}

/// The n-th derivative of a detector's output along the state equations (and the loops'
/// unknowns' rates), memoised.
fn output_derivative(
    pool: &mut Pool<V>,
    (rhs, loop_rates): (&[VId], &[VId]),
    outputs: &HashMap<Handle<Sensor>, VId>,
    memo: &mut HashMap<(Handle<Sensor>, u32), VId>,
    (sensor, n): (Handle<Sensor>, u32),
) -> VId {
    if let Some(&e) = memo.get(&(sensor, n)) {
        return e;
    }
    let e = if n == 0 {
        outputs
            .get(&sensor)
            .copied()
            .unwrap_or_else(|| pool.num(0.0))
    } else {
        let lower = output_derivative(pool, (rhs, loop_rates), outputs, memo, (sensor, n - 1));
        let mut d = Derivatives::new(|p: &mut Pool<V>, leaf: V| match leaf {
            V::Loop(k) => loop_rates.get(k.index()).copied(),
            other => plant_rate(p, rhs, other),
        });
        d.of(pool, lower).unwrap_or_else(|| pool.num(0.0))
    };
    memo.insert((sensor, n), e);
    e
}

/// The terms of `e` read as a sum (signs dropped: only their size matters).
/// The numerator of `e`, through negations and quotients at its top.
fn numerator(pool: &Pool<V>, mut e: VId) -> VId {
    loop {
        match pool.node(e) {
            Node::Neg(a) | Node::Binary(BinOp::Div, a, _) => e = a,
            _ => return e,
        }
    }
}

fn top_terms(pool: &Pool<V>, e: VId, out: &mut Vec<VId>) {
    let mut stack = vec![e];
    while let Some(e) = stack.pop() {
        match pool.node(e) {
            Node::Binary(BinOp::Add | BinOp::Sub, a, b) => stack.extend([a, b]),
            Node::Neg(a) => stack.push(a),
            _ => out.push(e),
        }
    }
}

/// The k-th test input and its n-th derivative at t: `scale (1 + 0.5 sin(w t + k))`, or
/// with [`Inputs::Reversing`] `1.5 scale sin(w t + k)`, whose sign changes.
fn input(k: usize, n: u32, t: f64, scale: f64, inputs: Inputs) -> f64 {
    let w = 1.3 + 0.7 * k as f64;
    let phase = w * t + k as f64;
    let d = w.powi(n as i32) * 0.5 * (phase + f64::from(n) * std::f64::consts::FRAC_PI_2).sin();
    scale
        * match inputs {
            Inputs::Reversing => 3.0 * d,
            Inputs::Offset if n == 0 => 1.0 + d,
            Inputs::Offset => d,
        }
}

/// The test inputs of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Inputs {
    /// Around the input scale, never below half of it: every model's domain holds them.
    Offset,
    /// Of mean zero, so that speeds and flows reverse: the runs that take a dry friction or
    /// an orifice through the zero crossings where its law switches.
    Reversing,
}

/// The n-th derivative of the additive sensor fault `size sin(2t + 1)` at t.
fn sensor_fault(n: u32, t: f64, size: f64) -> f64 {
    size * 2f64.powi(n as i32) * (2.0 * t + 1.0 + f64::from(n) * std::f64::consts::FRAC_PI_2).sin()
}

/// One simulation: the plant's parameters, the detector's, and a faulty sensor if any.
#[derive(Clone)]
struct Run<'a> {
    plant: &'a Plant,
    plant_params: Vec<f64>,
    nominal: Vec<f64>,
    faulty_sensor: Option<Handle<Sensor>>,
    faulty_input: Option<Handle<Input>>,
    fault_size: f64,
    options: &'a VerifyOptions,
    inputs: Inputs,
    /// The loops' unknowns last solved: Newton's next guess.
    guess: std::cell::RefCell<Vec<f64>>,
    /// The roots last solved: Newton's next guess for them.
    root_guess: std::cell::RefCell<Vec<f64>>,
}

impl Run<'_> {
    fn leaf<'r>(
        &'r self,
        x: &'r [f64],
        t: f64,
        z: &'r [f64],
        roots: &'r [f64],
    ) -> impl Fn(V) -> f64 + 'r {
        move |leaf| match leaf {
            V::State(k) => x[k.index()],
            V::Loop(k) => z[k.index()],
            // Only the residuals read roots, and `roots` holds them when they are evaluated.
            V::Root(k) => roots[k.index()],
            V::Estimate(k) => x[self.plant.states + k.index()],
            V::Plant(p) => self.plant_params[p.index()],
            V::Nominal(p) => self.nominal[p.index()],
            V::Input(u, n) => input(u.index(), n, t, self.options.input_scale, self.inputs),
            V::SensorFault(s, n) if Some(s) == self.faulty_sensor => {
                sensor_fault(n, t, self.fault_size)
            }
            V::SensorFault(..) => 0.0,
            V::InputFault(u, n) if Some(u) == self.faulty_input => {
                sensor_fault(n, t, self.fault_size)
            }
            V::InputFault(..) => 0.0,
            V::Time => t,
        }
    }

    fn integrals(&self, x: &[f64]) -> HashMap<VId, f64> {
        let n = self.plant.rhs.len();
        self.plant
            .integrals
            .iter()
            .enumerate()
            .map(|(i, &id)| (id, x[n + i]))
            .collect()
    }

    /// The values of `tape`'s roots in state `x` at time `t`, the loops' unknowns solved
    /// first.
    fn values(&self, tape: &Tape<V>, x: &[f64], t: f64) -> Vec<f64> {
        let integrals = self.integrals(x);
        // Every `int(..)` of the plant is integrated with it.
        let integral = |id: VId| integrals[&id];
        let z = self.loops(x, t, &integral);
        // Only the residuals read roots.
        let roots = if std::ptr::eq(tape, &self.plant.residual_tape)
            || std::ptr::eq(tape, &self.plant.crossing_tape)
        {
            self.roots(x, t, &z, &integral)
        } else {
            Vec::new()
        };
        tape.values(self.leaf(x, t, &z, &roots), integral, &mut Vec::new())
    }

    /// The roots the ARRs read in state `x` at time `t`, by Newton's method from the last
    /// ones, as a residual generator finds them (NaN where it finds none: the residuals then
    /// fail, never pass).
    fn roots(&self, x: &[f64], t: f64, z: &[f64], integral: &dyn Fn(VId) -> f64) -> Vec<f64> {
        if self.plant.roots == 0 {
            return Vec::new();
        }
        let mut r = self.root_guess.borrow().clone();
        let solved = crate::newton::solve(&mut r, |r, out| {
            *out = (self.plant.root_tape).values(self.leaf(x, t, z, r), integral, &mut Vec::new());
        });
        match solved {
            Ok(()) => {
                self.root_guess.borrow_mut().clone_from(&r);
                r
            }
            Err(_) => vec![f64::NAN; self.plant.roots],
        }
    }

    /// The loops' unknowns in state `x` at time `t`, by Newton's method from the last
    /// solution (NaN where it finds no root: the residuals then fail, never pass).
    fn loops(&self, x: &[f64], t: f64, integral: &dyn Fn(VId) -> f64) -> Vec<f64> {
        if self.plant.loops == 0 {
            return Vec::new();
        }
        let mut z = self.guess.borrow().clone();
        let solved = crate::newton::solve(&mut z, |z, out| {
            *out =
                (self.plant.loop_tape).values(self.leaf(x, t, z, &[]), integral, &mut Vec::new());
        });
        match solved {
            Ok(()) => {
                self.guess.borrow_mut().clone_from(&z);
                z
            }
            Err(_) => vec![f64::NAN; self.plant.loops],
        }
    }

    fn derivative(&self, x: &[f64], t: f64) -> Vec<f64> {
        self.values(&self.plant.derivative_tape, x, t)
    }

    /// Each residual and the size of its largest term.
    fn residuals(&self, x: &[f64], t: f64) -> Vec<(f64, f64)> {
        let values = self.values(&self.plant.residual_tape, x, t);
        let (residuals, mut terms) = values.split_at(self.plant.residuals.len());
        let mut out = Vec::with_capacity(residuals.len());
        for (&r, own) in residuals.iter().zip(&self.plant.terms) {
            let (mine, rest) = terms.split_at(own.len());
            terms = rest;
            out.push((r, mine.iter().map(|v| v.abs()).fold(0.0, f64::max)));
        }
        out
    }

    /// The largest |output| of each detector along an RK4 trajectory from `x0`.
    fn peaks(&self, x0: &[f64]) -> Result<Vec<f64>, VerifyError> {
        let mut peaks = vec![0.0f64; self.plant.outputs.len()];
        self.simulate(x0, |run, x, t| {
            let values = run.values(&run.plant.output_tape, x, t);
            for (p, v) in peaks.iter_mut().zip(values) {
                *p = p.max(v.abs());
            }
        })?;
        Ok(peaks)
    }

    /// Integrates the plant from `x0` with RK4, calling `visit` at every step.
    fn simulate(
        &self,
        x0: &[f64],
        mut visit: impl FnMut(&Self, &[f64], f64),
    ) -> Result<(), VerifyError> {
        let h = self.options.step;
        let mut x = self.start(x0);
        for step in 0..self.options.steps {
            let t = step as f64 * h;
            visit(self, &x, t);
            x = self.rk4(&x, t, h);
            if x.iter().any(|v| !v.is_finite()) {
                return Err(VerifyError::Diverged(t));
            }
        }
        Ok(())
    }

    /// The state one RK4 step of `h` after `x` at `t`.
    fn rk4(&self, x: &[f64], t: f64, h: f64) -> Vec<f64> {
        let add = |x: &[f64], k: &[f64], s: f64| -> Vec<f64> {
            x.iter().zip(k).map(|(a, b)| a + s * b).collect()
        };
        let k1 = self.derivative(x, t);
        let k2 = self.derivative(&add(x, &k1, h / 2.0), t + h / 2.0);
        let k3 = self.derivative(&add(x, &k2, h / 2.0), t + h / 2.0);
        let k4 = self.derivative(&add(x, &k3, h), t + h);
        (0..x.len())
            .map(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
            .collect()
    }

    /// Where a switching argument crosses zero along an RK4 trajectory from `x0`, how much
    /// each integrated residual's level jumps across the crossing, beyond what its rate
    /// accounts for. A relation taken as the derivative of its level holds pointwise on
    /// either side of a crossing even when the level jumps there (`d/dt sign(v)` taken as
    /// 0); only the level's continuity across it makes the integrated residual hold through
    /// it. The walk stops, keeping what it found, where a value leaves the finite numbers
    /// (inputs of mean zero may take a model out of its domain).
    fn crossings(&self, x0: &[f64], found: &mut Crossings) {
        let h = self.options.step;
        let tape = &self.plant.crossing_tape;
        let mut x = self.start(x0);
        let mut now = self.values(tape, &x, 0.0);
        let mut count = 0;
        for step in 0..self.options.steps {
            let t = step as f64 * h;
            let next_x = self.rk4(&x, t, h);
            let next = self.values(tape, &next_x, t + h);
            if (next_x.iter().chain(&now).chain(&next)).any(|v| !v.is_finite()) {
                found.stopped += 1;
                return;
            }
            found.sizes(self.plant.switches, &now);
            let crossed = (0..self.plant.switches).filter(|&k| now[k] * next[k] < 0.0);
            let first = crossed
                .map(|k| (self.locate(&x, t, k, now[k] > 0.0), k))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((tau, k)) = first.filter(|_| count < MOST_CROSSINGS_PER_RUN) {
                count += usize::from(self.jumps_at(&x, t, (tau, k), found));
            }
            (x, now) = (next_x, next);
        }
    }

    /// The time into the step from `x` at `t` at which switching argument `k`, positive at
    /// its start or not, changes sign, by bisection to the last bits of the step.
    fn locate(&self, x: &[f64], t: f64, k: usize, positive: bool) -> f64 {
        let (mut before, mut after) = (0.0, self.options.step);
        for _ in 0..52 {
            let mid = 0.5 * (before + after);
            let v = self.values(&self.plant.crossing_tape, &self.rk4(x, t, mid), t + mid)[k];
            if (v > 0.0) == positive && v != 0.0 {
                before = mid;
            } else {
                after = mid;
            }
        }
        0.5 * (before + after)
    }

    /// Each integrated level's jump across the crossing of switching argument `k` at `tau`
    /// into the step from `x` at `t`, recorded in `found`; false when the argument does not
    /// change sign over the short interval around `tau` (a tangency), which is not checked.
    fn jumps_at(&self, x: &[f64], t: f64, (tau, k): (f64, usize), found: &mut Crossings) -> bool {
        let tape = &self.plant.crossing_tape;
        // Short enough that the level's smooth change over it is far below round-off once
        // the rate is accounted for; long enough that the argument visibly changes sign.
        let half = CROSSING_HALF_WIDTH * self.options.step;
        let start = (tau - half).max(0.0);
        let before_x = if start > 0.0 {
            self.rk4(x, t, start)
        } else {
            x.to_vec()
        };
        let width = tau + half - start;
        let after_x = self.rk4(&before_x, t + start, width);
        let before = self.values(tape, &before_x, t + start);
        let after = self.values(tape, &after_x, t + start + width);
        if before[k] * after[k] >= 0.0 {
            return false;
        }
        let (s, n) = (self.plant.switches, self.plant.integrated.len());
        for j in 0..n {
            // Across the interval the level moves by −∫rate; what is left is its jump.
            let moved = after[s + j] - before[s + j];
            let jump = (moved + 0.5 * width * (after[s + n + j] + before[s + n + j])).abs();
            found.jumps[j] = found.jumps[j].max(if jump.is_nan() { f64::INFINITY } else { jump });
        }
        found.sizes(s, &before);
        found.sizes(s, &after);
        found.crossed += 1;
        true
    }

    /// The plant's, the copy's and the integrals' initial values from the plant's `x0`.
    fn start(&self, x0: &[f64]) -> Vec<f64> {
        let mut x: Vec<f64> = x0.to_vec();
        // The copy of the model simulated residuals run starts where the plant does.
        if self.plant.rhs.len() > self.plant.states {
            x.extend(self.plant.starts.iter().map(|&k| x0[k]));
        }
        x.extend(std::iter::repeat_n(0.0, self.plant.integrals.len()));
        x
    }

    /// Largest |residual| of each ARR along an RK4 trajectory from `x0`, relative to the
    /// largest term it met on the way: residuals are in the model's units (m^3/s for a tank,
    /// N for a mass), so only their size against their own terms says how far from zero.
    fn worst(&self, x0: &[f64]) -> Result<Vec<f64>, VerifyError> {
        let n = self.plant.residuals.len();
        let (mut worst, mut size) = (vec![0.0f64; n], vec![0.0f64; n]);
        self.simulate(x0, |run, x, t| {
            for (k, (r, s)) in run.residuals(x, t).into_iter().enumerate() {
                // A residual that is not finite is as wrong as one that is large.
                worst[k] = if r.is_finite() {
                    worst[k].max(r.abs())
                } else {
                    f64::INFINITY
                };
                size[k] = size[k].max(s);
            }
        })?;
        Ok(worst
            .iter()
            .zip(&size)
            .map(|(&w, &s)| {
                if w == 0.0 {
                    0.0
                } else {
                    w / s.max(f64::MIN_POSITIVE)
                }
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A relation printed `(A − B)/k = 0` is judged on `A − B` against its two terms, not as
    /// one term of relative size 1 (which failed right ARRs).
    #[test]
    fn a_quotient_is_judged_on_its_numerator_terms() {
        let model =
            "model m\nparam R1 = 2\ninput u\nSe s = u\nR r = R1\nDf f on j\ns -> 1:j -> r\n";
        let c = bondgraph_core::compile(model, "m.bg", &bondgraph_core::Options::default())
            .expect("compiles")
            .compiled;
        let input = c.inputs.iter().next().expect("an input").0;
        let parameter = c.parameters.iter().next().expect("a parameter").0;
        let mut pool: Pool<V> = Pool::default();
        let (a, b) = (pool.leaf(V::Time), pool.leaf(V::Input(input, 0)));
        let k = pool.leaf(V::Nominal(parameter));
        let difference = pool.sub(a, b);
        let quotient = pool.div(difference, k);
        let negated = pool.neg(quotient);
        assert_eq!(numerator(&pool, negated), difference);
        let mut terms = Vec::new();
        top_terms(&pool, numerator(&pool, negated), &mut terms);
        terms.sort();
        let mut expected = vec![a, b];
        expected.sort();
        assert_eq!(terms, expected);
    }

    /// The two-mass drive with its load's dry friction `Fc*sign(w2)`, compiled.
    fn two_mass_drive() -> Compiled {
        let model = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/two_mass_friction.bg"
        ))
        .expect("the shipped model");
        bondgraph_core::compile(&model, "two_mass_friction.bg", &Default::default())
            .expect("compiles")
            .compiled
    }

    /// What bgc wrote before it refused to differentiate through a dry friction: the load
    /// side's equation differentiated with d/dt sign(w2) taken as 0, which drops the Coulomb
    /// term, realised by integration. Its level `(cs w1 − J2 w2' − (cs + b2) w2)/k` holds
    /// `w2'`, which jumps by 2 Fc/J2 at each reversal of the load, so its integrated
    /// residual jumps by 2 Fc/k (5 mrad) there, while the relation holds pointwise.
    fn differentiated_through_the_friction(c: &mut Compiled) {
        let parameter = |c: &Compiled, name: &str| {
            let h = c.parameters.find(|p| p.name == name).expect(name);
            Symbol::Parameter(h)
        };
        let sensor = |name: &str| c.sensors.find(|s| s.name == name).expect(name);
        let (w1, w2) = (sensor("w1"), sensor("w2"));
        let [cs, b2, j2, k] = ["cs", "b2", "J2", "k"].map(|n| parameter(c, n));
        let p = &mut c.exprs;
        let [cs, b2, j2, k] = [cs, b2, j2, k].map(|s| p.leaf(s));
        let [w1, w2, dw2] = [(w1, 0), (w2, 0), (w2, 1)].map(|(s, n)| p.leaf(Symbol::Sensor(s, n)));
        let twist = p.mul(cs, w1);
        let inertia = p.mul(j2, dw2);
        let damping = p.add(cs, b2);
        let damping = p.mul(damping, w2);
        let numerator = p.sub(twist, inertia);
        let numerator = p.sub(numerator, damping);
        let level = p.div(numerator, k);
        let rate = p.sub(w1, w2);
        let mut d = Derivatives::new(bondgraph_core::time_rate);
        let d_level = d.of(p, level).expect("a derivative");
        let expr = p.add(rate, d_level);
        let int_rate = p.int(rate);
        let evaluated = p.add(level, int_rate);
        let arr = &mut c.arrs[0];
        arr.expr = expr;
        let Realisation::Integrated(i) = &mut arr.realisation else {
            panic!("ARR1 is realised by integration");
        };
        (i.level, i.rate, i.expr) = (level, rate, evaluated);
    }

    /// `verify` takes every integrated relation through zero crossings of the dry
    /// friction's speed (runs with inputs of mean zero reverse the load) and checks that its
    /// level does not jump there: the shipped relations pass, and the relation differentiated
    /// through `sign(w2)` fails there although it holds at every sample.
    #[test]
    fn verify_fails_a_relation_differentiated_through_a_dry_friction() {
        let mut c = two_mass_drive();
        let right = verify(&c, &VerifyOptions::default()).expect("verifies");
        assert!(right.passed(), "{right:?}");
        assert!(right.crossings.crossed >= 4, "{:?}", right.crossings);
        assert!(right.arrs.iter().all(|a| a.jump.is_some_and(|j| j < 1e-12)));
        differentiated_through_the_friction(&mut c);
        let wrong = verify(&c, &VerifyOptions::default()).expect("verifies");
        let arr = &wrong.arrs[0];
        assert!(arr.worst < 1e-12, "it holds pointwise: {arr:?}");
        let jump = arr.jump.expect("checked across the reversals");
        assert!(jump > 1e-3, "it jumps at each reversal: {arr:?}");
        assert!(!arr.pass && !wrong.passed());
    }

    /// A stiffening spring whose force runs out of the finite numbers from the default
    /// initial states, after the start: verify finds a scale of its own and passes, where it
    /// used to stop and ask the user for one.
    #[test]
    fn verify_finds_a_scale_the_model_stays_finite_at() {
        let model = "model stiffening\nparam m = 1\nparam b = 0.5\nparam k1 = 4\nparam a = 100\n\
                     input F\nSe src = F\nI mass = m\nR damper = b\n\
                     C spring : e = k1*q*exp(a*q^2)\nDf v on j\n\
                     src -> 1:j -> mass, damper, spring\n";
        let c = bondgraph_core::compile(model, "m.bg", &bondgraph_core::Options::default())
            .expect("compiles")
            .compiled;
        let mut seen = Vec::new();
        let v = verify_reporting(&c, &VerifyOptions::default(), &mut |p| seen.push(p))
            .expect("a finite run was found");
        assert!(v.scalings > 0 && v.state_scale < 0.5, "{}", v.state_scale);
        assert!(v.passed());
        // Progress counts the components of the attempt, at the scale it tries.
        let n = c.components.len();
        assert!(seen.iter().all(|p| p.of == n && p.components < n));
        let last = seen.last().expect("progress was reported");
        assert_eq!((last.components, last.scale), (n - 1, v.state_scale));
    }
}
