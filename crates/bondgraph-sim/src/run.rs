//! Integrating the plant over the scenario and sampling what a bench would record.
//!
//! The solver is the `differential-equations` crate's: Dormand–Prince 5(4) for models that
//! are not stiff, Kværnø's ESDIRK 5(4) (implicit, L-stable) for stiff ones, both adaptive with
//! dense output. (Its Radau IIA does not run on a state whose size is known only at run
//! time, as a model's is, in version 0.7.) The run is cut at every kink of a fault's course and in pieces of at most a
//! hundredth of the duration (for progress), and restarted at each cut from the state there.

use std::cell::{Cell, RefCell};
use std::fmt;

use differential_equations::prelude::Error as SolverError;
use differential_equations::prelude::{
    ControlFlag, DiagonallyImplicitRungeKutta, ExplicitRungeKutta, Interpolation, Solout, Solution,
    IVP, ODE,
};

use crate::newton;
use crate::noise::gaussian;
use crate::plant::{Plant, P};
use crate::scenario::Quantiser;
use crate::scenario::{Scenario, Solver};

/// Sampled signals of a simulation: one column per name, one row per output time.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// `t`, then the inputs as commanded, the states, and the measured signals as reported.
    pub columns: Vec<String>,
    /// Each column's samples.
    pub values: Vec<Vec<f64>>,
    /// How many steps the solver took, accepted and rejected.
    pub steps: (usize, usize),
    /// How many times the right-hand side was evaluated.
    pub evaluations: usize,
}

/// Why a simulation stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum SimulationError {
    /// The solver gave up at this time.
    Solver {
        /// Where.
        at: f64,
        /// What it said.
        reason: String,
    },
    /// A state or recorded signal became infinite or not a number at this time.
    NotFinite {
        /// Where.
        at: f64,
        /// Which signal.
        signal: String,
    },
    /// Newton's method found no value of the nonlinear algebraic loops' unknowns.
    NoLoopSolution {
        /// Where.
        at: f64,
        /// The loops' unknowns.
        unknowns: Vec<String>,
        /// The largest |residual| where Newton's method stopped.
        residual: f64,
    },
}

impl fmt::Display for SimulationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimulationError::Solver { at, reason } => {
                write!(f, "the solver stopped at t = {at} s: {reason}")
            }
            SimulationError::NotFinite { at, signal } => write!(
                f,
                "`{signal}` is not a finite number at t = {at} s: the model diverges, or divides by zero"
            ),
            SimulationError::NoLoopSolution {
                at,
                unknowns,
                residual,
            } => write!(
                f,
                "Newton's method found no value of the algebraic loop unknown(s) {} at t = {at} s \
                 (it stopped with a residual of {residual:e}): the loop's laws have no common solution \
                 there, or it is far from the last one; check the laws' signs, or shorten `step`",
                unknowns
                    .iter()
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

impl std::error::Error for SimulationError {}

/// The right-hand side as the solver calls it.
struct Rhs<'p> {
    plant: &'p Plant,
    /// The tape's workspace, its roots' values, and the loops' unknowns at the last call
    /// (the next call's first guess), reused at every call.
    scratch: RefCell<(Vec<f64>, Vec<f64>, Vec<f64>)>,
    /// Where, and with what residual, Newton's method last failed on the loops.
    failed: Cell<Option<(f64, f64)>>,
}

impl Plant {
    /// The value of each leaf at `t` in state `y`, with the loops' unknowns `z`.
    fn leaves<'a>(&'a self, t: f64, y: &'a [f64], z: &'a [f64]) -> impl Fn(P) -> f64 + 'a {
        move |leaf| match leaf {
            P::State(k) => y[k.index()],
            P::Loop(k) => z[k.index()],
            P::Param(k) => self.params[k.index()].at(t),
            P::Fault(k) => self.faults[k as usize].at(t),
            P::Time => t,
            // Put in when the plant was built.
            P::Input(_) | P::InputDer(..) => f64::NAN,
        }
    }

    fn integral<'a>(&'a self, y: &'a [f64]) -> impl Fn(bondgraph_core::ExprId<P>) -> f64 + 'a {
        // Every `int(..)` of the plant has a state of its own, after the model's.
        move |id| y[self.integrals[&id]]
    }
}

impl Plant {
    /// Solves the loops' unknowns at `t` in state `y`, from the guess in `z`.
    fn solve_loops(
        &self,
        t: f64,
        y: &[f64],
        z: &mut Vec<f64>,
        work: &mut Vec<f64>,
    ) -> Result<(), newton::NoRoot> {
        if self.loop_names.is_empty() {
            return Ok(());
        }
        z.resize(self.loop_names.len(), 0.0);
        newton::solve(z, |z, r| {
            self.loops
                .values_into(self.leaves(t, y, z), self.integral(y), work, r);
        })
    }
}

impl ODE<f64, Vec<f64>> for Rhs<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        let p = self.plant;
        let mut scratch = self.scratch.borrow_mut();
        let (work, values, z) = &mut *scratch;
        if let Err(e) = p.solve_loops(t, y, z, work) {
            // The solver sees a step it cannot take; the run reports why.
            self.failed.set(Some((t, e.residual)));
            dydt.fill(f64::NAN);
            return;
        }
        p.derivative
            .values_into(p.leaves(t, y, z), p.integral(y), work, values);
        for (d, v) in dydt.iter_mut().zip(values.iter()) {
            *d = *v;
        }
    }
}

/// Most solver steps in one piece of the run (a hundredth of it): far more than a smooth
/// model needs, few enough to stop a chattering one in seconds.
const MAX_STEPS: usize = 1_000_000;

/// Runs the plant over the scenario; `progress` hears the fraction done after each piece.
pub(crate) fn run(
    plant: &Plant,
    scenario: &Scenario,
    mut progress: impl FnMut(f64),
) -> Result<Trajectory, SimulationError> {
    let h = scenario.output_step;
    let samples = (scenario.duration / h).round() as usize;
    let end = samples as f64 * h;
    let mut cuts: Vec<f64> = plant.breaks.clone();
    let pieces = 100usize;
    cuts.extend((1..pieces).map(|k| end * k as f64 / pieces as f64));
    cuts.push(end);
    cuts.retain(|&c| c > 0.0 && c <= end);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * end.max(1.0));

    let inputs = plant.inputs;
    let mut names: Vec<String> = plant.recorded_names[..inputs].to_vec();
    names.extend(plant.state_names[..plant.model_states].iter().cloned());
    names.extend(plant.recorded_names[inputs..].iter().cloned());
    let mut out = Trajectory {
        columns: std::iter::once("t".to_string()).chain(names).collect(),
        values: vec![
            Vec::with_capacity(samples + 1);
            1 + plant.recorded_names.len() + plant.model_states
        ],
        steps: (0, 0),
        evaluations: 0,
    };
    let rhs = Rhs {
        plant,
        scratch: RefCell::new((Vec::new(), Vec::new(), Vec::new())),
        failed: Cell::new(None),
    };
    let mut y = plant.initial.clone();
    let mut start = 0.0;
    let mut next = 0usize;
    // The loops' unknowns at the last sample: the next sample's first guess.
    let mut z = Vec::new();
    let no_root = |at: f64, e: newton::NoRoot| SimulationError::NoLoopSolution {
        at,
        unknowns: plant.loop_names.clone(),
        residual: e.residual,
    };
    let sample = |out: &mut Trajectory, z: &mut Vec<f64>, k: usize, t: f64, y: &[f64]| {
        plant
            .solve_loops(t, y, z, &mut Vec::new())
            .map_err(|e| no_root(t, e))?;
        record(plant, scenario, out, k, t, y, z)
    };
    sample(&mut out, &mut z, 0, 0.0, &y)?;
    next += 1;
    for &cut in &cuts {
        // Output times inside (start, cut], and the cut itself to restart from.
        let first = next;
        let mut points: Vec<f64> = Vec::new();
        // An output time within rounding of the cut is the cut: a point past the end of the
        // piece would be dropped by the solver.
        let near = 1e-9 * h;
        while next <= samples && next as f64 * h < cut - near {
            points.push(next as f64 * h);
            next += 1;
        }
        if next <= samples && (next as f64 * h - cut).abs() <= near {
            next += 1;
        }
        points.push(cut);
        starts_finite(&rhs, start, &y)?;
        let solution = solve(&rhs, scenario, start, cut, y.clone(), &points);
        // A failed trial step the solver recovered from by a shorter one is no failure.
        if let (Err(_), Some((at, residual))) = (&solution, rhs.failed.take()) {
            return Err(no_root(at, newton::NoRoot { residual }));
        }
        let solution = solution?;
        out.steps.0 += solution.steps.0;
        out.steps.1 += solution.steps.1;
        out.evaluations += solution.evaluations;
        for (&t, state) in solution.t.iter().zip(&solution.y) {
            let k = (t / h).round() as usize;
            if k >= first && k < next && (t - k as f64 * h).abs() <= 1e-9 * h {
                sample(&mut out, &mut z, k, t, state)?;
            }
        }
        if let Some(last) = solution.y.last() {
            y.clone_from(last);
        }
        start = cut;
        progress(cut / end);
    }
    quantise(plant, scenario, &mut out);
    Ok(out)
}

/// Set in a signal's number for an encoder's first count, apart from its noise's numbers.
const PHASE: u64 = 1 << 40;

/// Each recorded signal with a quantiser read through it, after its noise: to a resolution,
/// the nearest multiple; through an encoder, the speed integrated to an angle (trapezoids
/// between samples), counted from a first count placed at random, and the counts'
/// difference over a sample taken as the speed (0 at the first sample, which has none
/// before it).
fn quantise(plant: &Plant, scenario: &Scenario, out: &mut Trajectory) {
    let h = scenario.output_step;
    for (i, how) in plant.quantisers.iter().enumerate() {
        let Some(how) = how else { continue };
        let column = if i < plant.inputs {
            1 + i
        } else {
            1 + plant.model_states + i
        };
        let x = &mut out.values[column];
        match *how {
            Quantiser::Resolution(q) => {
                for v in x.iter_mut() {
                    *v = (*v / q).round() * q;
                }
            }
            Quantiser::Encoder(counts) => {
                let quantum = std::f64::consts::TAU / counts;
                let phase = crate::noise::uniform(scenario.seed, PHASE | i as u64, 0);
                let mut angle = 0.0;
                let mut last = phase.floor();
                let mut previous = x.first().copied().unwrap_or(0.0);
                for (k, v) in x.iter_mut().enumerate() {
                    if k > 0 {
                        angle += 0.5 * (previous + *v) * h;
                    }
                    previous = *v;
                    let count = (angle / quantum + phase).floor();
                    *v = (count - last) * quantum / h;
                    last = count;
                }
            }
        }
    }
}

/// Whether every state's derivative at `t` in state `y` is a finite number, as the solver
/// needs to choose its first step: where one is not, the solver only said "Initial step size
/// (0.0) cannot be zero". Says which state's derivative is not.
fn starts_finite(rhs: &Rhs<'_>, t: f64, y: &[f64]) -> Result<(), SimulationError> {
    let mut dydt = vec![0.0; y.len()];
    rhs.diff(t, &y.to_vec(), &mut dydt);
    if let Some((at, residual)) = rhs.failed.take() {
        return Err(SimulationError::NoLoopSolution {
            at,
            unknowns: rhs.plant.loop_names.clone(),
            residual,
        });
    }
    match dydt.iter().position(|d| !d.is_finite()) {
        Some(k) => Err(SimulationError::NotFinite {
            at: t,
            signal: format!("der({})", rhs.plant.state_names[k]),
        }),
        None => Ok(()),
    }
}

/// The solution at given times inside each step (dense output), and at the end of the piece
/// from the last step itself: the solver's last step may stop a rounding short of the end,
/// where an interpolated point would be dropped.
struct Samples {
    points: Vec<f64>,
    next: usize,
    /// Within this of the end, a step is the last.
    near_end: f64,
    end: f64,
}

impl Samples {
    fn new(points: &[f64], from: f64, to: f64) -> Samples {
        Samples {
            points: points.to_vec(),
            next: 0,
            near_end: 1e-10 * (to - from).abs().max(f64::MIN_POSITIVE),
            end: to,
        }
    }
}

impl Solout<f64, Vec<f64>> for Samples {
    fn solout<I>(
        &mut self,
        t_curr: f64,
        t_prev: f64,
        y_curr: &Vec<f64>,
        _y_prev: &Vec<f64>,
        interpolator: &mut I,
        solution: &mut Solution<f64, Vec<f64>>,
    ) -> ControlFlag<f64, Vec<f64>>
    where
        I: Interpolation<f64, Vec<f64>> + ?Sized,
    {
        let last = self.end - t_curr <= self.near_end;
        while let Some(&t) = self.points.get(self.next) {
            if t <= t_prev {
                self.next += 1;
                continue;
            }
            if t >= t_curr || last && t > t_curr {
                if t > t_curr && !last {
                    break;
                }
                solution.push(t, y_curr.clone());
            } else {
                match interpolator.interpolate(t) {
                    Ok(y) => solution.push(t, y),
                    Err(_) => break,
                }
            }
            self.next += 1;
        }
        ControlFlag::Continue
    }
}

/// One solved piece.
struct Piece {
    t: Vec<f64>,
    y: Vec<Vec<f64>>,
    steps: (usize, usize),
    evaluations: usize,
}

fn solve(
    rhs: &Rhs<'_>,
    scenario: &Scenario,
    from: f64,
    to: f64,
    y0: Vec<f64>,
    points: &[f64],
) -> Result<Piece, SimulationError> {
    let rtol = scenario.tolerance;
    let atol = scenario.tolerance * 1e-3;
    let h_max = scenario.output_step.min(to - from);
    let explicit = || {
        IVP::ode(rhs, from, to, y0.clone())
            .solout(Samples::new(points, from, to))
            .method(
                ExplicitRungeKutta::dopri5()
                    .rtol(rtol)
                    .atol(atol)
                    .h_max(h_max)
                    .max_steps(MAX_STEPS),
            )
            .solve()
    };
    let implicit = || {
        IVP::ode(rhs, from, to, y0.clone())
            .solout(Samples::new(points, from, to))
            .method(
                DiagonallyImplicitRungeKutta::kvaerno745()
                    .rtol(rtol)
                    .atol(atol)
                    .h_max(h_max)
                    .max_steps(MAX_STEPS),
            )
            .solve()
    };
    let solution = match scenario.solver {
        Solver::DormandPrince => explicit(),
        Solver::Implicit => implicit(),
        Solver::Auto => match explicit() {
            Err(SolverError::Stiffness { .. }) => implicit(),
            other => other,
        },
    };
    let solution = solution.map_err(|e| SimulationError::Solver {
        at: match &e {
            SolverError::MaxSteps { t, .. }
            | SolverError::StepSize { t, .. }
            | SolverError::Stiffness { t, .. }
            | SolverError::LinearAlgebra { t, .. } => *t,
            _ => from,
        },
        reason: reason(&e),
    })?;
    Ok(Piece {
        t: solution.t,
        y: solution.y,
        steps: (solution.steps.accepted, solution.steps.rejected),
        evaluations: solution.evals.function,
    })
}

fn reason(e: &SolverError<f64, Vec<f64>>) -> String {
    match e {
        SolverError::MaxSteps { .. } => format!(
            "more than {MAX_STEPS} steps in a hundredth of the run: the state chatters, as a law \
             with sign() or abs() does where its argument stays at zero (a Coulomb friction that \
             sticks); smooth the law (e.g. tanh(v/eps) for sign(v)) or drive the model past it"
        ),
        SolverError::StepSize { .. } => {
            "the step became too small (a discontinuity the solver cannot pass, or a state that diverges)".to_string()
        }
        SolverError::Stiffness { .. } => {
            "the model is stiff: use `solver implicit` or `solver auto`".to_string()
        }
        SolverError::LinearAlgebra { msg, .. } => format!("a singular Newton matrix ({msg})"),
        // Its wording ("Invalid input: Initial step size (0.0) cannot be zero") names the
        // solver's settings, which bgc chose: what a user can act on is the model's state.
        SolverError::BadInput { .. } => "it could not choose a step from there: the state's \
            derivatives are too large or change too fast (a state that diverges, a division by \
            a signal near zero)"
            .to_string(),
        _ => "an internal error of the solver".to_string(),
    }
}

/// Writes the k-th sample: time, inputs, states, measured signals (noise added).
fn record(
    plant: &Plant,
    scenario: &Scenario,
    out: &mut Trajectory,
    k: usize,
    t: f64,
    y: &[f64],
    z: &[f64],
) -> Result<(), SimulationError> {
    let mut scratch = Vec::new();
    let recorded = plant
        .recorded
        .values(plant.leaves(t, y, z), plant.integral(y), &mut scratch);
    let inputs = plant.inputs;
    let mut row = Vec::with_capacity(out.values.len());
    row.push(t);
    let noisy = |i: usize, v: f64| v + plant.noise[i] * gaussian(scenario.seed, i as u64, k as u64);
    row.extend(
        recorded[..inputs]
            .iter()
            .enumerate()
            .map(|(i, &v)| noisy(i, v)),
    );
    row.extend(&y[..plant.model_states]);
    row.extend(
        recorded[inputs..]
            .iter()
            .enumerate()
            .map(|(i, &v)| noisy(inputs + i, v)),
    );
    for (column, (v, name)) in out.values.iter_mut().zip(row.into_iter().zip(&out.columns)) {
        if !v.is_finite() {
            return Err(SimulationError::NotFinite {
                at: t,
                signal: name.clone(),
            });
        }
        column.push(v);
    }
    Ok(())
}
