//! Identification: the model's parameters fitted to healthy records.
//!
//! The residual program is the equation error of the model: on a healthy record of the
//! plant, every residual would vanish if the parameters were the plant's and the signals
//! exact. The parameters are fitted by least squares on the residuals as the program
//! realises them (integrated over a window where they can be, so that no second derivative
//! of a measured signal is read), by the same generator `bgc residuals` runs, each residual
//! divided by the noise it carries at the current parameters ([`noise`]): the whitened fit,
//! which neither lets a relation shrink towards zero everywhere nor lets a parameter that
//! multiplies a noisy signal ignore the noise it brings. The relation between a residual and
//! the parameters is whatever the ARR makes it, so the fit is Levenberg–Marquardt on the
//! logarithms of the parameters (a parameter keeps its sign; a product of parameters the
//! records cannot split shows as a direction of scalings), with sensitivities by central
//! differences of the generator. It grows its horizon from a few seconds to the whole
//! records, each stretch starting from the fit of the one before, so that a model error
//! integrated from the start does not carry a nonlinear law far from where the plant works
//! before the fit has corrected it. Estimates within the reach of a jump of a signal (a
//! square input's edge) are left out ([`jumps`]).
//!
//! What the records determine is read from the fit's information matrix: a direction along
//! which no residual moves (to rounding, relative to the best-determined one) is a
//! combination of parameters the records cannot tell apart; the fit leaves the model's
//! values along it. Whether the ARRs themselves hold that combination only (no record can
//! separate it) or this record's excitation does not separate it is told by evaluating the
//! residual program at random values of its signals with the parameters moved along that
//! direction.
//!
//! The intervals allow for what least squares on a time series must: successive residuals
//! are correlated (an estimator's window, an integration window, integrals from the start),
//! so the covariance is the sandwich `H⁻¹ B H⁻¹` with `B` estimated from batch means of the
//! score over stretches much longer than those windows, and the interval is Student's with
//! as many degrees of freedom as batches less one.

use std::sync::OnceLock;

use bondgraph_core::program::{Evaluation, Leaf, Program};
use bondgraph_core::{Compiled, Evaluator, ResidualForm};

use crate::fit::{Estimator, Fit, Integration};
use crate::generator::{Estimated, Estimates, Generator};
use crate::linalg::{dot, eigen_symmetric, Square};

mod criterion;
mod jumps;
mod noise;
mod prefix;
mod scaling;
mod substeps;

pub use criterion::{
    identify_by, simulate_record, simulation_error, Chosen, Criteria, Criterion, Evidence, HELD_OUT,
};
pub use prefix::Prefix;

use noise::Probe;
use scaling::Scaling;

/// A record to fit: its times and its raw columns in the program's raw order.
pub struct Record<'a> {
    /// The time of each sample.
    pub time: &'a [f64],
    /// One column per raw signal of the program.
    pub raw: Vec<&'a [f64]>,
    /// The generator (of the same program, fitted as the settings say) after the samples
    /// before these: each evaluation goes on from its state with the parameters tried, so
    /// that a span late in a long record is fitted without running what came before it
    /// again, and with the values that held there. `None`: from rest.
    pub state: Option<&'a Prefix>,
}

/// What to fit, and how.
#[derive(Clone, Debug)]
pub struct Settings {
    /// How the residuals are estimated while fitting.
    pub fit: Fit,
    /// The parameters to fit, by their place in the model; empty: every one the residual
    /// program reads but the sensors' and actuators' faults (`with`).
    pub free: Vec<usize>,
    /// Keep each parameter within the model's `+- x%` where it gives one.
    pub bounded: bool,
    /// Fit only the estimates of a span of the records (which are still run from their
    /// start, for what the program integrates from there): the size of a fault since its
    /// alarm. `None`: every estimate.
    pub span: Option<Span>,
}

/// A span of the records to fit: the estimates whose instants lie in `[from, to]` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Its first instant.
    pub from: f64,
    /// Its last instant.
    pub to: f64,
    /// Where residuals integrated from the start are taken from.
    pub origin: Origin,
}

/// Where residuals integrated from the start are taken from, over a span.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// From the span's start: what a fault adds while it lasts, whatever came before.
    Span,
    /// From the record's start: where a relation is the rate of a law (the bench's link),
    /// its integral is the law itself, which a change of the law's parameters moves even
    /// where its rate does not (a dead zone's width, once the twist is past it).
    Record,
}

/// How well the records determine one parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Determined {
    /// Fitted, with an interval.
    Yes,
    /// Fitted, but its interval is wider than its value: the records hardly tell it.
    Weakly,
    /// Only in combination with others (see [`Identification::undetermined`]): left at
    /// the model's value along the combinations the records cannot see.
    No,
    /// No residual reads it.
    Unread,
    /// Not fitted: held at the given value.
    Held,
    /// The fit ran away with it (see [`Identification::lost`]): held at its start.
    Lost,
}

/// A parameter the fit ran away with, held at its start while the others were fitted.
#[derive(Clone, Debug, PartialEq)]
pub struct Lost {
    /// The parameter, by its place in the model.
    pub parameter: usize,
    /// Its name.
    pub name: String,
    /// Where the fit was taking it (possibly not a number).
    pub towards: f64,
}

/// One parameter's estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The parameter, by its place in the model.
    pub parameter: usize,
    /// Its name.
    pub name: String,
    /// The value it was fitted from.
    pub start: f64,
    /// The fitted value.
    pub value: f64,
    /// Its standard error (infinite where not determined).
    pub std_error: f64,
    /// The half-width of its 95 % interval.
    pub half_width: f64,
    /// How well the records determine it.
    pub determined: Determined,
    /// Whether the fit stopped at the model's `+- x%`.
    pub at_bound: bool,
    /// Whether the fit moved it by a shift, so that it may cross zero (an offset, a bias:
    /// a value of 0 or below, or one only sources read), rather than by a factor.
    pub signed: bool,
}

/// A combination of parameters the records do not determine: scaling each parameter by
/// `s^exponent` (any `s`) leaves every residual as it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Combination {
    /// Each parameter concerned (by its place in the model) and its exponent, the largest
    /// magnitude 1.
    pub scalings: Vec<(usize, f64)>,
    /// Whether the ARRs themselves cannot separate them (no record can), rather than this
    /// record's excitation.
    pub structural: bool,
}

/// Why a fit stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The cost stopped decreasing.
    Converged,
    /// The iteration limit.
    Iterations,
}

/// What identification found.
#[derive(Clone, Debug)]
pub struct Identification {
    /// Every parameter of the model, fitted where the records determine it.
    pub values: Vec<f64>,
    /// Each parameter's estimate, in the model's order.
    pub estimates: Vec<Estimate>,
    /// The combinations the records do not determine.
    pub undetermined: Vec<Combination>,
    /// The condition number of the fitted parameters' normalised information matrix (on
    /// the determined ones).
    pub condition: f64,
    /// Each residual's RMS at the start and at the fit.
    pub rms: Vec<(f64, f64)>,
    /// The mean square of the residuals, each over the noise it carries, at the start and
    /// at the fit: 1 is a fit to the noise.
    pub cost: (f64, f64),
    /// The samples fitted (estimates times residuals), and the batches the intervals rest
    /// on.
    pub samples: usize,
    /// How many batches of samples the intervals rest on.
    pub batches: usize,
    /// How the fit stopped, after how many iterations.
    pub stop: (Stop, usize),
    /// How many jumps of a signal the records hold (see [`Identification::left_out`]).
    pub jumps: usize,
    /// How many estimates were left out of the fit because a jump of a signal was within
    /// their windows' reach, where the estimators' assumptions fail.
    pub left_out: usize,
    /// The parameters the fit ran away with, held at their starts.
    pub lost: Vec<Lost>,
    /// The fit again with the estimators' windows halved, whose moves widen the intervals;
    /// `None` where no window could be halved or that fit failed.
    pub reach: Option<Reach>,
}

/// What the estimators' windows do to the estimates: the fit made again with them halved.
/// An estimator's bias grows with its window (a smoother flattens a resonance; an
/// integration window weighs an unmodelled slow error more), at least in proportion: so the
/// bias at the windows used is at most twice what halving them changes, and each interval
/// is widened by that. On the EMPS axis the mass read 94.4, 93.5 and 91.9 kg over
/// integration windows of 125, 250 and 500 samples, each within a ±1 % interval.
#[derive(Clone, Debug, PartialEq)]
pub struct Reach {
    /// The estimators' window and the longest integration window of the second fit.
    pub windows: (usize, usize),
    /// Each fitted parameter (by its place in the model) and its value in the second fit.
    pub values: Vec<(usize, f64)>,
}

/// Why identification could not be done.
#[derive(Clone, Debug, PartialEq)]
pub enum IdentifyError {
    /// The estimator cannot be built (see the message).
    Estimator(String),
    /// No residual is a number anywhere on the records.
    NoSamples,
    /// Too few estimates to fit and to tell the intervals.
    TooShort {
        /// The estimates there are.
        estimates: usize,
        /// The least the fit needs.
        needed: usize,
    },
}

impl std::fmt::Display for IdentifyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IdentifyError::Estimator(e) => f.write_str(e),
            IdentifyError::NoSamples => f.write_str("no residual is a number on these records"),
            IdentifyError::TooShort { estimates, needed } => write!(
                f,
                "{estimates} estimates: identification needs at least {needed} (five batches \
                 of eight times the estimator's and the integration's windows, as the \
                 residuals use them)"
            ),
        }
    }
}

impl std::error::Error for IdentifyError {}

/// The relative eigenvalue under which a direction of the normalised information matrix
/// counts as unseen: central differences leave about 1e-10 of a column (rounding over the
/// step, and the step squared), so an exact null direction shows at about 1e-20, and one
/// the records barely excite far above 1e-10.
const UNSEEN: f64 = 1e-10;

/// The relative change of a parameter the sensitivities are taken over.
const DIFFERENCE: f64 = 1e-6;

/// Most Levenberg–Marquardt iterations per round.
const ITERATIONS: usize = 60;

/// How far from its start, as a factor, a fit may drive a parameter before it is held there
/// (see [`identify`]); and before the combinations it takes part in are no longer called
/// structural.
const RUNAWAY: f64 = 1e6;

/// Fresh draws of the signals' noise the intervals' second estimate rests on.
const REPLICATES: usize = 20;

/// Most batches for the intervals.
const MOST_BATCHES: usize = 20;

/// Fewest batches for the intervals: Student's quantile with four degrees of freedom
/// (2.78) widens them for what so few batches leave unknown.
const LEAST_BATCHES: usize = 5;

/// Fits the parameters of `c` (its residual program `program`) to `records`, from the
/// values `start` (in the model's order).
///
/// The fit never ends above the cost it started from, and never returns a value out of all
/// proportion to its start: a parameter the fit runs away with (more than [`RUNAWAY`]
/// times its start, or not a number) is held at its start and the others are fitted again;
/// [`Identification::lost`] names it with where it was going.
pub fn identify(
    c: &Compiled,
    program: &Program,
    start: &[f64],
    records: &[Record<'_>],
    settings: &Settings,
) -> Result<Identification, IdentifyError> {
    let read = read_parameters(program, start.len());
    let mut free: Vec<usize> = if settings.free.is_empty() {
        let plant: Vec<bool> = c.parameters.values().map(|p| p.carried.is_none()).collect();
        (0..start.len()).filter(|&k| read[k] && plant[k]).collect()
    } else {
        settings.free.iter().copied().filter(|&k| read[k]).collect()
    };
    let mut lost = Vec::new();
    let substeps = records.first().map_or(1, |r| {
        substeps::substeps(c, program, start, (r.time, &r.raw), &settings.fit)
    });
    // Each round holds at least one more parameter, so there are at most as many rounds as
    // parameters.
    loop {
        let problem = Problem::new(c, program, records, settings, start, &free, substeps);
        let first = problem.evaluate(&vec![0.0; free.len()])?;
        problem.check_length(first.rows)?;
        let (u, stop) = fit(&problem, &first)?;
        let values = problem.values(&u);
        let ran: Vec<usize> = (free.iter().copied())
            .filter(|&k| problem.scalings[k].ran_away(start[k], values[k], RUNAWAY))
            .collect();
        if !ran.is_empty() {
            lost.extend(ran.iter().map(|&k| {
                Lost {
                    parameter: k,
                    name: c
                        .parameters
                        .values()
                        .nth(k)
                        .map(|p| p.name.clone())
                        .unwrap_or_default(),
                    towards: values[k],
                }
            }));
            free.retain(|k| !ran.contains(k));
            continue;
        }
        let mut found = problem.summarise(&u, first.raw_rms.clone(), &read, stop)?;
        let per_sample = |s: &Samples| s.cost() / (s.rows * s.residuals).max(1) as f64;
        let last = problem.evaluate(&u)?;
        found.cost = (per_sample(&first), per_sample(&last));
        found.jumps = (problem.records.iter())
            .map(|r| jumps::jumps(&r.raw).len())
            .sum();
        found.left_out = problem.left_out.iter().flatten().filter(|&&x| x).count();
        for l in &lost {
            found.estimates[l.parameter].determined = Determined::Lost;
        }
        found.lost = lost;
        if settings.span.is_none() {
            found.reach = problem.halved(&u);
            widen(&mut found);
        }
        return Ok(found);
    }
}

/// The fit of the parameters `free` from `start`: the coordinates reached and how the last
/// round stopped. `first` holds the residuals at the start over the whole records.
///
/// The fit grows its horizon: over a short first stretch the model's error has not yet
/// accumulated in what the relations integrate from the start (the bench's twist, from the
/// two encoders and the gear ratio), so the fit starts near its basin; each longer stretch
/// starts from the fit of the one before. Where that path ends above the start's cost over
/// the whole records (a short stretch's minimum that the whole does not share), the fit is
/// made again from the start over the whole records, which can only go down.
fn fit(problem: &Problem<'_>, first: &Samples) -> Result<(Vec<f64>, (Stop, usize)), IdentifyError> {
    let Problem {
        c,
        program,
        records,
        start,
        substeps,
        ..
    } = *problem;
    let settings = problem.settings;
    let free = &problem.free;
    let mut u = vec![0.0; free.len()];
    let total = records.iter().map(|r| r.time.len()).max().unwrap_or(0);
    let mut length = problem.first_horizon();
    // Over a span, the fit starts where the span does.
    if settings.span.is_some() {
        length = total;
    }
    while length < total {
        let heads: Vec<Record<'_>> = records.iter().map(|r| r.head(length)).collect();
        let stage = Problem::new(c, program, &heads, settings, start, free, substeps);
        if stage.evaluate(&u).is_ok() {
            stage.minimise(&mut u)?;
        }
        length *= 2;
    }
    let staged = problem
        .evaluate(&u)
        .is_ok_and(|s| s.dropped <= first.dropped && s.cost() <= first.cost());
    if !staged {
        u.fill(0.0);
    }
    let stop = problem.minimise(&mut u)?;
    Ok((u, stop))
}

/// Widens each determined estimate's interval by twice its move in [`Identification::reach`]
/// (see [`Reach`]).
fn widen(found: &mut Identification) {
    let Some(reach) = &found.reach else {
        return;
    };
    for &(k, halved) in &reach.values {
        let e = &mut found.estimates[k];
        if !matches!(e.determined, Determined::Yes | Determined::Weakly) || !halved.is_finite() {
            continue;
        }
        e.half_width += 2.0 * (halved - e.value).abs();
        if e.half_width > e.value.abs() {
            e.determined = Determined::Weakly;
        }
    }
}

/// `fit` with its estimator's window and every integration window halved where they can be
/// (an odd window longer than the estimator's degree needs, an integration of one sample at
/// least); `None` where none can.
fn halve(fit: &Fit, residuals: usize) -> Option<Fit> {
    let half = |w: usize, least: usize| Some((w / 2) | 1).filter(|&h| h >= least && h < w);
    let estimator = match fit.estimator {
        Estimator::SavitzkyGolay { window, degree } => half(window, degree as usize + 2)
            .map(|window| Estimator::SavitzkyGolay { window, degree }),
        Estimator::Modulating { window } => {
            half(window, 11).map(|window| Estimator::Modulating { window })
        }
    };
    let integration: Vec<Integration> = (0..residuals)
        .map(
            |k| match fit.integration.get(k).copied().unwrap_or_default() {
                Integration::Window(n) => Integration::Window((n / 2).max(1)),
                Integration::Start => Integration::Start,
            },
        )
        .collect();
    let halved = Fit {
        step: fit.step,
        estimator: estimator.unwrap_or(fit.estimator),
        integration,
    };
    (estimator.is_some() || halved.integration != fit.integration).then_some(halved)
}

/// The integration window (in samples) for a record of `rows` samples fitted with an
/// estimator window of `window`: the runtime's default (250) where the record holds five
/// batches of eight times the two windows, else the largest that leaves them (at least 1),
/// so that a short record (1,024 samples of a slow process) is fitted rather than refused.
/// Whether it was shrunk is the second value.
pub fn integration_window_for(rows: usize, window: usize) -> (usize, bool) {
    let default = bondgraph::Reference::DEFAULT_WINDOW;
    // The estimates are the samples less the window's; a few more for its rounding.
    let estimates = rows.saturating_sub(2 * window);
    let room = (estimates / (LEAST_BATCHES * 8))
        .saturating_sub(window)
        .max(1);
    if room >= default {
        (default, false)
    } else {
        (room, true)
    }
}

/// The parameters to fit, by their place in `c`: those named in `only` (when it is empty,
/// every one but the sensors' and actuators' faults) less those named in `fix`. A name the model does not declare is refused, with
/// the nearest one it does.
pub fn choose_free(c: &Compiled, only: &[String], fix: &[String]) -> Result<Vec<usize>, String> {
    let names: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    let place = |name: &String| {
        names.iter().position(|n| n == name).ok_or_else(|| {
            let hint = bondgraph_core::closest(name, names.iter().copied())
                .map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
            format!("the model has no parameter `{name}`{hint}")
        })
    };
    let only = only.iter().map(place).collect::<Result<Vec<_>, _>>()?;
    let fixed = fix.iter().map(place).collect::<Result<Vec<_>, _>>()?;
    // A sensor's or an actuator's fault (`with`) is a departure from health, not a property
    // of the plant: held at its healthy value unless named (an encoder's gain and the mass
    // it reads scale one relation together, and could never both be learned).
    let candidates: Vec<usize> = if only.is_empty() {
        (c.parameters.values().enumerate())
            .filter(|(_, p)| p.carried.is_none())
            .map(|(k, _)| k)
            .collect()
    } else {
        only
    };
    Ok(candidates
        .into_iter()
        .filter(|k| !fixed.contains(k))
        .collect())
}

/// Which parameters the program reads anywhere: residuals, integrands, roots, the copy.
fn read_parameters(program: &Program, count: usize) -> Vec<bool> {
    // A root's slope is its law's derivative: it reads no parameter the law does not.
    let roots = program.parametrised();
    let mut read = vec![false; count];
    program.code.visit_reachable(&roots, |_, node| {
        if let bondgraph_core::Node::Leaf(Leaf::Parameter(p)) = node {
            read[p.index()] = true;
        }
    });
    read
}

/// Each parameter's bounds on its fit coordinate, from the model's `+- x%`.
fn bounds(c: &Compiled, start: &[f64], scalings: &[Scaling], bounded: bool) -> Vec<(f64, f64)> {
    (c.parameters.values().zip(start).zip(scalings))
        .map(|((p, &v), &scaling)| match (p.uncertainty, scaling) {
            (Some(half), Scaling::Factor) if bounded && v != 0.0 && half < v.abs() => {
                let r = half / v.abs();
                ((1.0 - r).ln(), (1.0 + r).ln())
            }
            (Some(half), Scaling::Shift(size)) if bounded => (-half / size, half / size),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        })
        .collect()
}

/// The residuals of every record at one set of values, row by row: row `i` holds the
/// residuals of one estimate, each divided by the noise it carries; rows where one is not a
/// number are dropped.
struct Samples {
    /// `rows × residuals`, row-major.
    values: Vec<f64>,
    residuals: usize,
    rows: usize,
    /// Each kept row's record and place in its record's estimates.
    at: Vec<(usize, usize)>,
    /// Each residual's RMS before it was divided by its noise.
    raw_rms: Vec<f64>,
    /// How many estimates had a residual that is not a number.
    dropped: usize,
    /// What each residual was divided by.
    scale: Vec<f64>,
}

impl Samples {
    fn rms(&self) -> Vec<f64> {
        let mut sums = vec![0.0; self.residuals];
        for row in self.values.chunks_exact(self.residuals) {
            for (s, r) in sums.iter_mut().zip(row) {
                *s += r * r;
            }
        }
        let n = self.rows.max(1) as f64;
        sums.into_iter().map(|s| (s / n).sqrt()).collect()
    }

    fn cost(&self) -> f64 {
        self.values.iter().map(|r| r * r).sum()
    }

    /// Divides each residual by `scale`.
    fn divide(&mut self, scale: &[f64]) {
        for row in self.values.chunks_exact_mut(self.residuals) {
            for (r, s) in row.iter_mut().zip(scale) {
                *r /= s;
            }
        }
    }
}

/// One identification problem.
struct Problem<'a> {
    c: &'a Compiled,
    program: &'a Program,
    records: &'a [Record<'a>],
    /// Each record's noise probe (see [`noise`]).
    probes: Vec<Option<Probe>>,
    fit: &'a Fit,
    settings: &'a Settings,
    start: &'a [f64],
    /// How each parameter of the model moves with its fit coordinate.
    scalings: Vec<Scaling>,
    /// Runge–Kutta steps per sample interval of the copy of the model, if one runs.
    substeps: usize,
    /// The fitted parameters, by their place in the model.
    free: Vec<usize>,
    bounds: Vec<(f64, f64)>,
    /// Each residual's weight where no noise reaches it.
    fallback: Vec<f64>,
    /// Each residual's noise where it is held at the start's (a simulated residual: see
    /// [`Problem::new`]).
    fixed: Vec<Option<f64>>,
    /// For each record, the estimates (by place) a jump of a signal reaches, or outside
    /// the span fitted.
    left_out: Vec<Vec<bool>>,
    /// Whether only a span of the records is fitted.
    span: bool,
    /// Whether residuals integrated from the start are taken from the span's start.
    from_span: bool,
    /// Each record's, then each probe's, estimators' output, made at its first run: no
    /// parameter changes it, and a fit runs every record through a generator of new
    /// parameters twice per free parameter per iteration.
    estimated: Vec<OnceLock<Option<Estimated>>>,
}

impl<'a> Record<'a> {
    /// The record's first `rows` samples.
    fn head(&self, rows: usize) -> Record<'a> {
        let rows = rows.min(self.time.len());
        Record {
            time: &self.time[..rows],
            raw: self.raw.iter().map(|c| &c[..rows]).collect(),
            state: self.state,
        }
    }
}

impl<'a> Problem<'a> {
    /// The problem of fitting the parameters `free` of `c` to `records` from `start`.
    fn new(
        c: &'a Compiled,
        program: &'a Program,
        records: &'a [Record<'a>],
        settings: &'a Settings,
        start: &'a [f64],
        free: &[usize],
        substeps: usize,
    ) -> Problem<'a> {
        let scalings = scaling::scalings(c, start);
        let mut problem = Problem {
            c,
            program,
            records,
            // Over a span the probe must reach it: the whole records then.
            probes: (records.iter().enumerate())
                .map(|(k, r)| {
                    let rows = if settings.span.is_some() {
                        usize::MAX
                    } else {
                        noise::PROBE_ROWS
                    };
                    Probe::of(r.time, &r.raw, 0x5DEE_CE66_D1CE_4E5B ^ k as u64, rows)
                })
                .collect(),
            fit: &settings.fit,
            settings,
            start,
            free: free.to_vec(),
            bounds: bounds(c, start, &scalings, settings.bounded),
            scalings,
            substeps,
            fallback: Vec::new(),
            fixed: Vec::new(),
            left_out: Vec::new(),
            span: settings.span.is_some(),
            from_span: settings.span.is_some_and(|s| s.origin == Origin::Span),
            estimated: (0..2 * records.len()).map(|_| OnceLock::new()).collect(),
        };
        let (window, integration) = problem.windows();
        problem.left_out = (records.iter())
            .map(|r| {
                // Over a span since an alarm, the fault moves the residuals far more than a
                // jump's error does, and the span is too short to lose what it reaches.
                let mut out = if settings.span.is_some() {
                    vec![false; r.time.len()]
                } else {
                    jumps::left_out(&r.raw, r.time.len(), window, integration)
                };
                if let Some(Span { from, to, .. }) = settings.span {
                    // An estimate's instant is its window's middle sample's; from a state,
                    // the windows are full from the first sample on.
                    let back = if r.state.is_some() { window - 1 } else { 0 };
                    for (p, o) in out.iter_mut().enumerate() {
                        let at = match (p + window / 2).checked_sub(back) {
                            Some(k) => r.time.get(k).copied().unwrap_or(f64::INFINITY),
                            None => f64::NEG_INFINITY,
                        };
                        *o |= !(from..=to).contains(&at);
                    }
                }
                out
            })
            .collect();
        // A residual no noise reaches (every signal it reads noise-free) is weighed by its
        // RMS with the model's values instead.
        if let Ok(first) = problem.evaluate(&vec![0.0; free.len()]) {
            problem.fallback = (first.raw_rms.iter())
                .map(|&r| if r > 0.0 { 1.0 / r } else { 1.0 })
                .collect();
            // A simulated residual (the output error) is weighed by the noise it carries at
            // the start, held there: its response to the inputs' noise runs through the
            // copy's dynamics, which the parameters scale, and a weight that followed them
            // would let the fit trade the output's misfit for a quieter copy (on the EMPS
            // axis the position's RMS error grew while the weighed cost fell).
            let simulated =
                |k: usize| c.arrs.get(k).map(|a| a.form) == Some(ResidualForm::Simulated);
            if (0..first.residuals).any(simulated) {
                if let Ok(weighed) = problem.evaluate(&vec![0.0; free.len()]) {
                    problem.fixed = (weighed.scale.iter().enumerate())
                        .map(|(k, &w)| simulated(k).then_some(w))
                        .collect();
                }
            }
        }
        problem
    }

    /// The first horizon of the fit: two stretches of correlated residuals, short enough
    /// that a model error integrated from the start (a gear ratio off by 2 % turns the
    /// bench's twist by tens of radians over minutes) has not carried a nonlinear law far
    /// from where the plant works. At least a 64th of the records, so that a residual
    /// correlated over a few samples only (a simulated one reads no window) does not start
    /// the fit on a handful of them.
    fn first_horizon(&self) -> usize {
        let total = self.records.iter().map(|r| r.time.len()).max().unwrap_or(0);
        (self.batch_length() / 2).max(total / 64)
    }
}

impl Problem<'_> {
    fn values(&self, u: &[f64]) -> Vec<f64> {
        let mut values = self.start.to_vec();
        for (&k, &x) in self.free.iter().zip(u) {
            values[k] = self.scalings[k].value(self.start[k], x);
        }
        values
    }

    /// The residuals at log-scalings `u`, each divided by the noise it carries there.
    fn evaluate(&self, u: &[f64]) -> Result<Samples, IdentifyError> {
        let values = self.values(u);
        let n = self.program.residuals.len();
        let mut samples = Samples {
            values: Vec::new(),
            residuals: n,
            rows: 0,
            at: Vec::new(),
            raw_rms: Vec::new(),
            dropped: 0,
            scale: Vec::new(),
        };
        for (r, record) in self.records.iter().enumerate() {
            let left_out = self.left_out.get(r);
            let kept = samples.rows;
            let cache = Some(&self.estimated[r]);
            let seen = self.run(
                &values,
                r,
                record.time,
                &record.raw,
                (cache, false),
                |place, row| {
                    if left_out.is_some_and(|l| l.get(place) == Some(&true)) {
                        return;
                    }
                    samples.values.extend_from_slice(row);
                    samples.at.push((r, place));
                    samples.rows += 1;
                },
            )?;
            let left = left_out.map_or(0, |l| l.iter().take(seen).filter(|&&x| x).count());
            samples.dropped += seen.saturating_sub(samples.rows - kept + left);
        }
        if samples.rows == 0 {
            return Err(IdentifyError::NoSamples);
        }
        samples.raw_rms = samples.rms();
        let gains = self.noise_gains(&values, &samples)?;
        let scale: Vec<f64> = (gains.iter().zip(&self.fallback).enumerate())
            .map(|(k, (&g, &w))| match g {
                _ if self.fixed.get(k).copied().flatten().is_some() => self.fixed[k].unwrap_or(1.0),
                Some(g) if g > 0.0 => g,
                _ if w > 0.0 => 1.0 / w,
                _ => samples.raw_rms[k].max(f64::MIN_POSITIVE),
            })
            .collect();
        samples.divide(&scale);
        samples.scale = scale;
        Ok(samples)
    }

    /// Runs the generator with the parameters `values` over samples, handing each
    /// estimate's place and residuals (where all are numbers) to `each`; the number of
    /// estimates. With `kept`, the estimators' output over these samples is taken from
    /// there, made there at the first run; `noisy`: the samples carry a probe's noise, and
    /// go on from the record's noisy prefix, if it has one.
    fn run(
        &self,
        values: &[f64],
        record: usize,
        time: &[f64],
        raw: &[&[f64]],
        (kept, noisy): (Option<&OnceLock<Option<Estimated>>>, bool),
        mut each: impl FnMut(usize, &[f64]),
    ) -> Result<usize, IdentifyError> {
        let n = self.program.residuals.len();
        let state = (self.records.get(record).and_then(|r| r.state)).map(|p| {
            if noisy {
                &p.noisy
            } else {
                &p.clean
            }
        });
        let generator = || {
            match state {
                Some(g) => g.with_parameters(self.c, self.program, values, self.fit),
                None => Generator::new(self.c, self.program, values, self.fit),
            }
            .map_err(|e| IdentifyError::Estimator(e.to_string()))
        };
        let estimated = match kept {
            Some(cell) => match cell.get() {
                Some(e) => e.as_ref(),
                None => cell
                    .get_or_init(|| {
                        let e = generator().ok()?.estimated(time, raw);
                        e.small_enough()
                    })
                    .as_ref(),
            },
            None => None,
        };
        let mut generator = generator()?.with_substeps(self.substeps);
        let mut place = 0;
        let mut row = vec![0.0; n];
        // Over a span, a residual integrated from the start is taken from the span's start:
        // its value at the last estimate before the span is the reference.
        let from_span: Vec<bool> = (0..n)
            .map(|k| {
                self.from_span
                    && self.program.residuals[k].evaluation == Evaluation::Integrated
                    && self.fit.integration.get(k) == Some(&Integration::Start)
            })
            .collect();
        let before_span = |p: usize| {
            self.span
                && (self.left_out.get(record))
                    .is_some_and(|l| l.get(p) == Some(&true) && l.get(p + 1) == Some(&false))
        };
        let mut reference = vec![0.0; n];
        let mut take = |estimates: &Estimates<'_>| {
            for i in 0..estimates.len() {
                for (k, x) in row.iter_mut().enumerate() {
                    *x = estimates.residual(k)[i];
                }
                if before_span(place) {
                    reference.copy_from_slice(&row);
                }
                for ((x, r), &taken) in row.iter_mut().zip(&reference).zip(&from_span) {
                    if taken {
                        *x -= r;
                    }
                }
                if row.iter().all(|v| v.is_finite()) {
                    each(place, &row);
                }
                place += 1;
            }
        };
        match estimated {
            Some(e) => generator.run_estimated(time, raw, e, false, &mut take),
            None => generator.run(time, raw, false, &mut take),
        }
        Ok(place)
    }

    /// Each residual's RMS response to the probes' noise (`None` where no probe reaches
    /// it), against the clean residuals of `samples` at the same places.
    fn noise_gains(
        &self,
        values: &[f64],
        samples: &Samples,
    ) -> Result<Vec<Option<f64>>, IdentifyError> {
        let n = samples.residuals;
        let mut sums = vec![0.0; n];
        let mut count = 0usize;
        let mut j = 0;
        for (r, probe) in self.probes.iter().enumerate() {
            let Some(probe) = probe else { continue };
            let raw: Vec<&[f64]> = probe.raw.iter().map(Vec::as_slice).collect();
            let cache = Some(&self.estimated[self.records.len() + r]);
            self.run(values, r, &probe.time, &raw, (cache, true), |place, row| {
                while j < samples.rows && samples.at[j] < (r, place) {
                    j += 1;
                }
                if j < samples.rows && samples.at[j] == (r, place) {
                    let clean = &samples.values[j * n..][..n];
                    for ((s, a), b) in sums.iter_mut().zip(row).zip(clean) {
                        *s += (a - b) * (a - b);
                    }
                    count += 1;
                }
            })?;
        }
        Ok(sums
            .into_iter()
            .map(|s| (count > 0).then(|| (s / count as f64).sqrt()))
            .collect())
    }

    /// The estimators' window and the longest integration window, in samples: each counted
    /// where some residual uses it (an estimate of a measured signal's value or derivative;
    /// a residual integrated over a window), so that a simulated residual, which reads
    /// neither, or a relation read as written, is not charged for an integration it does
    /// not make.
    fn windows(&self) -> (usize, usize) {
        let window = match self.fit.estimator {
            Estimator::SavitzkyGolay { window, .. } | Estimator::Modulating { window } => window,
        };
        let estimates = (self.program.slots.values())
            .any(|s| matches!(s.fill, bondgraph_core::program::Fill::Estimate { .. }));
        let integration = (self.program.residuals.iter().enumerate())
            .filter(|(_, r)| r.evaluation == Evaluation::Integrated)
            .map(
                |(k, _)| match self.fit.integration.get(k).copied().unwrap_or_default() {
                    Integration::Window(n) => n,
                    Integration::Start => 0,
                },
            )
            .max()
            .unwrap_or(0);
        (if estimates { window } else { 1 }, integration)
    }

    /// The estimates a stretch of correlated residuals spans.
    fn correlation(&self) -> usize {
        let (window, integration) = self.windows();
        window + integration
    }

    fn batch_length(&self) -> usize {
        8 * self.correlation()
    }

    fn check_length(&self, rows: usize) -> Result<(), IdentifyError> {
        // A span since an alarm is short by nature: its intervals rest on the replicates.
        let needed = if self.span {
            self.windows().0
        } else {
            LEAST_BATCHES * self.batch_length()
        };
        if rows < needed {
            return Err(IdentifyError::TooShort {
                estimates: rows,
                needed,
            });
        }
        Ok(())
    }

    /// The sensitivities of the weighted residuals to each log-scaling at `u` by central
    /// differences, each a column over the rows of `base` (a row either side lacks gives 0).
    fn jacobian(&self, u: &[f64], base: &Samples) -> Result<Vec<Vec<f64>>, IdentifyError> {
        let mut columns = Vec::with_capacity(self.free.len());
        for j in 0..self.free.len() {
            let mut up = u.to_vec();
            up[j] += DIFFERENCE;
            let mut down = u.to_vec();
            down[j] -= DIFFERENCE;
            let (up, down) = (self.evaluate(&up)?, self.evaluate(&down)?);
            columns.push(difference(base, &up, &down, DIFFERENCE));
        }
        Ok(columns)
    }

    /// Levenberg–Marquardt from `u`, in place.
    fn minimise(&self, u: &mut [f64]) -> Result<(Stop, usize), IdentifyError> {
        let n = self.free.len();
        if n == 0 {
            return Ok((Stop::Converged, 0));
        }
        let mut current = self.evaluate(u)?;
        let mut cost = current.cost();
        // A step that makes a residual not a number somewhere (an exponential overflowing)
        // is no improvement, however small the rest.
        let dropped = current.dropped;
        let mut damping = 1e-3;
        for iteration in 1..=ITERATIONS {
            let columns = self.jacobian(u, &current)?;
            let system = Normal::new(&columns, &current);
            let mut improved = false;
            for _ in 0..20 {
                let step = system.step(damping);
                let trial: Vec<f64> = (u.iter().zip(&step).enumerate())
                    .map(|(j, (x, d))| {
                        let (lo, hi) = self.bounds[self.free[j]];
                        (x + d).clamp(lo, hi)
                    })
                    .collect();
                // A step where no residual is a number anywhere is refused like one that
                // loses some: the copy of a simulated residual may diverge there.
                let Ok(candidate) = self.evaluate(&trial) else {
                    damping *= 4.0;
                    continue;
                };
                let trial_cost = if candidate.dropped > dropped {
                    f64::INFINITY
                } else {
                    candidate.cost()
                };
                if trial_cost.is_finite() && trial_cost <= cost {
                    let moved = trial.iter().zip(u.iter()).map(|(a, b)| (a - b).abs());
                    let largest = moved.fold(0.0, f64::max);
                    let gain = (cost - trial_cost) / cost.max(f64::MIN_POSITIVE);
                    u.copy_from_slice(&trial);
                    current = candidate;
                    cost = trial_cost;
                    damping = (damping / 3.0).max(1e-12);
                    improved = true;
                    if gain < 1e-12 || largest < 1e-10 {
                        return Ok((Stop::Converged, iteration));
                    }
                    break;
                }
                damping *= 4.0;
            }
            if !improved {
                return Ok((Stop::Converged, iteration));
            }
        }
        Ok((Stop::Iterations, ITERATIONS))
    }

    /// The fit made again from `u` with the estimators' windows halved (see [`Reach`]);
    /// `None` where they cannot be, or where halving changes no window a residual uses,
    /// or that fit fails.
    fn halved(&self, u: &[f64]) -> Option<Reach> {
        let fit = halve(self.fit, self.program.residuals.len())?;
        let settings = Settings {
            fit,
            ..self.settings.clone()
        };
        let problem = Problem::new(
            self.c,
            self.program,
            self.records,
            &settings,
            self.start,
            &self.free,
            self.substeps,
        );
        let windows = problem.windows();
        if windows == self.windows() {
            return None;
        }
        let mut v = u.to_vec();
        problem.evaluate(&v).ok()?;
        problem.minimise(&mut v).ok()?;
        let values = problem.values(&v);
        Some(Reach {
            windows,
            values: self.free.iter().map(|&k| (k, values[k])).collect(),
        })
    }

    /// The estimates, their intervals and what the records do not determine, at `u`.
    fn summarise(
        &self,
        u: &[f64],
        before: Vec<f64>,
        read: &[bool],
        stop: (Stop, usize),
    ) -> Result<Identification, IdentifyError> {
        let base = self.evaluate(u)?;
        let columns = self.jacobian(u, &base)?;
        let system = Normal::new(&columns, &base);
        let batches = self.batches(&base);
        let sandwich = system.sandwich(&columns, &base, &batches);
        let replicated = self.replicated(u, &base, &columns, &system)?;
        let values = self.values(u);
        let t = student_975(batches.len().saturating_sub(1).max(1));
        let t_replicated = student_975(REPLICATES - 1);
        // The wider of the two: batch means see what the records hold beyond the noise
        // model (a model error), the replicates every correlation the noise takes on.
        let half_widths: Vec<f64> = (0..self.free.len())
            .map(|j| {
                let r = replicated
                    .as_ref()
                    .map_or(0.0, |v| t_replicated * v[j].sqrt());
                (t * sandwich[j].sqrt()).max(r)
            })
            .collect();
        let undetermined = self.undetermined(&system, &values);
        let mut estimates: Vec<Estimate> = (self.c.parameters.values().enumerate())
            .map(|(k, p)| Estimate {
                parameter: k,
                name: p.name.clone(),
                start: self.start[k],
                value: values[k],
                std_error: f64::INFINITY,
                half_width: f64::INFINITY,
                determined: if read[k] {
                    Determined::Held
                } else {
                    Determined::Unread
                },
                at_bound: false,
                signed: self.scalings[k].signed(),
            })
            .collect();
        for (j, &k) in self.free.iter().enumerate() {
            let e = &mut estimates[k];
            let (lo, hi) = self.bounds[k];
            e.at_bound = u[j] <= lo || u[j] >= hi;
            let hidden = undetermined
                .iter()
                .any(|c| c.scalings.iter().any(|&(p, x)| p == k && x.abs() > 1e-3));
            if hidden {
                e.determined = Determined::No;
                continue;
            }
            // The covariance is of the fit's coordinates: to first order, the value's is
            // the coordinate's times the slope squared.
            let slope = self.scalings[k].slope(values[k]);
            e.half_width = half_widths[j] * slope;
            e.std_error = e.half_width / t;
            e.determined = if e.half_width > values[k].abs() {
                Determined::Weakly
            } else {
                Determined::Yes
            };
        }
        let after = base.raw_rms.clone();
        Ok(Identification {
            values,
            estimates,
            undetermined,
            condition: system.condition(),
            rms: before.into_iter().zip(after).collect(),
            cost: (0.0, 0.0),
            samples: base.rows * base.residuals,
            batches: batches.len(),
            stop,
            jumps: 0,
            left_out: 0,
            lost: Vec::new(),
            reach: None,
        })
    }

    /// The variance of each log-scaling that the signals' noise alone leaves, from the
    /// fit's linear response to [`REPLICATES`] fresh draws of it over the whole records:
    /// every correlation the program puts into the residuals, the random walk of an
    /// integral read from the start included, which batch means over stretches of the
    /// record cannot see. `None` where no signal has any noise.
    fn replicated(
        &self,
        u: &[f64],
        base: &Samples,
        columns: &[Vec<f64>],
        system: &Normal,
    ) -> Result<Option<Vec<f64>>, IdentifyError> {
        let values = self.values(u);
        let n = base.residuals;
        let mut variance = vec![0.0; self.free.len()];
        let mut any = false;
        for m in 0..REPLICATES {
            let mut score = vec![0.0; self.free.len()];
            let mut j = 0;
            for (r, record) in self.records.iter().enumerate() {
                let seed = 0xA076_1D64_78BD_642F ^ ((m as u64) << 16) ^ r as u64;
                let Some(noisy) = Probe::of(record.time, &record.raw, seed, usize::MAX) else {
                    continue;
                };
                any = true;
                let raw: Vec<&[f64]> = noisy.raw.iter().map(Vec::as_slice).collect();
                self.run(&values, r, &noisy.time, &raw, (None, true), |place, row| {
                    while j < base.rows && base.at[j] < (r, place) {
                        j += 1;
                    }
                    if j < base.rows && base.at[j] == (r, place) {
                        for (k, x) in row.iter().enumerate() {
                            let d = x / base.scale[k] - base.values[j * n + k];
                            for (s, c) in score.iter_mut().zip(columns) {
                                *s += c[j * n + k] * d;
                            }
                        }
                    }
                })?;
            }
            for (v, d) in variance.iter_mut().zip(system.response(&score)) {
                *v += d * d / REPLICATES as f64;
            }
        }
        Ok(any.then_some(variance))
    }

    /// The rows of each batch: consecutive stretches of one record, as long as
    /// [`Problem::batch_length`] at least, at most [`MOST_BATCHES`] in all.
    fn batches(&self, base: &Samples) -> Vec<std::ops::Range<usize>> {
        let length = (base.rows / MOST_BATCHES).max(self.batch_length());
        let mut batches = Vec::new();
        let mut start = 0;
        for i in 1..=base.rows {
            let boundary = i == base.rows || base.at[i].0 != base.at[start].0;
            if i - start >= length || boundary {
                // A short tail of a record joins its last batch.
                if i - start < length / 2 && !batches.is_empty() && !boundary {
                    continue;
                }
                batches.push(start..i);
                start = i;
            }
        }
        batches
    }

    /// The combinations of the fitted parameters along which the normalised information
    /// matrix has (relatively) no curvature.
    fn undetermined(&self, system: &Normal, values: &[f64]) -> Vec<Combination> {
        let (eigenvalues, vectors) = eigen_symmetric(&system.normalised);
        let top = eigenvalues.first().copied().unwrap_or(0.0);
        (eigenvalues.iter().zip(&vectors))
            .filter(|(&l, _)| l <= UNSEEN * top)
            .map(|(_, v)| {
                // Back from the normalised coordinates to log-scalings: `D H D v = 0` is
                // `H (D v) = 0`.
                let raw: Vec<f64> = (v.iter().zip(&system.scale))
                    .map(|(x, s)| if *s > 0.0 { x * s } else { *x })
                    .collect();
                let largest = raw.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let scalings: Vec<(usize, f64)> = (self.free.iter().zip(&raw))
                    .map(|(&k, &x)| (k, x / largest))
                    .filter(|(_, x)| x.abs() > 1e-3)
                    .collect();
                // A fit that ran a parameter to nothing (1e-28 of its value) makes any
                // scaling of it flat there, which says nothing of what the ARRs hold. (The
                // check cannot be made at the model's values instead: a sum `R1 + R2` is flat
                // along exponents that depend on where it is taken.)
                let ran_away = (scalings.iter())
                    .any(|&(k, _)| self.scalings[k].ran_away(self.start[k], values[k], RUNAWAY));
                let structural = !ran_away && self.structural(&scalings, values);
                Combination {
                    scalings,
                    structural,
                }
            })
            .collect()
    }

    /// Whether moving the parameters along `scalings` leaves every residual as it is up to
    /// a constant factor of its own, to first order, at random values of its signals: then
    /// no record can separate them (a residual scaled by a constant is scaled with its
    /// noise, and the whitened fit does not see it: a tank's section, its pump's gain and
    /// its orifice's coefficient scaled together). An integral's integrand may scale too,
    /// by a constant, the integral then with it; an implicit law may scale (its root stays);
    /// the copy's rates must stay as they are. The move is small (1e-4 in log-scaling), so
    /// that a combination the ARRs hold as a sum (`R1 + R2`), flat only to first order along
    /// a scaling, counts too; a direction the ARRs see changes an expression's ratio by
    /// about the move, one they do not by its square.
    fn structural(&self, scalings: &[(usize, f64)], values: &[f64]) -> bool {
        let mut moved = values.to_vec();
        for &(k, x) in scalings {
            moved[k] = self.scalings[k].value(values[k], 1e-4 * x);
        }
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let ratios: Option<Vec<Vec<Option<f64>>>> = (0..3)
            .map(|_| {
                let point: Vec<f64> = (0..self.program.slots.len())
                    .map(|_| 0.5 + uniform(&mut state))
                    .collect();
                self.ratios(&point, values, &moved)
            })
            .collect();
        let Some(ratios) = ratios else {
            return false;
        };
        // Each expression's ratio, the same at every point.
        (0..ratios[0].len()).all(|r| {
            let seen: Vec<f64> = ratios.iter().filter_map(|p| p[r]).collect();
            seen.windows(2)
                .all(|w| (w[0] - w[1]).abs() <= 1e-6 * w[0].abs().max(w[1].abs()))
        })
    }

    /// At one point of the signals (`point`, a value per slot), each expression's ratio of
    /// its value with the parameters `moved` to its value with `values` (`None` where both
    /// vanish): the integrands' first, then the laws', then the residuals' (their integrals
    /// scaled by their integrands' ratios). `None` where an expression that must stay as it
    /// is (the copy's rates) does not, or one vanishes with one set and not the other.
    fn ratios(&self, point: &[f64], values: &[f64], moved: &[f64]) -> Option<Vec<Option<f64>>> {
        let program = self.program;
        let value = |params: &[f64], scale: &[f64], code| {
            Evaluator::new(&program.code, |leaf: Leaf| match leaf {
                Leaf::Slot(s) => point[s.index()] * scale[s.index()],
                Leaf::Parameter(p) => params[p.index()],
                Leaf::Time => 0.7,
                Leaf::State(_) | Leaf::Input(_) => 0.3,
            })
            .value(code)
        };
        let ratio = |a: f64, b: f64| -> Option<Option<f64>> {
            let tiny = 1e-300;
            match (a.abs() <= tiny, b.abs() <= tiny) {
                (true, true) => Some(None),
                (false, false) if a.is_finite() && b.is_finite() => Some(Some(b / a)),
                _ if a.is_nan() && b.is_nan() => Some(None),
                _ => None,
            }
        };
        let ones = vec![1.0; program.slots.len()];
        let mut scale = ones.clone();
        let mut out = Vec::new();
        for (h, slot) in program.slots.iter() {
            let code = match slot.fill {
                bondgraph_core::program::Fill::Integral(code) => code,
                bondgraph_core::program::Fill::Root { residual, .. } => residual,
                _ => continue,
            };
            let r = ratio(value(values, &ones, code), value(moved, &ones, code))?;
            if matches!(slot.fill, bondgraph_core::program::Fill::Integral(_)) {
                scale[h.index()] = r.unwrap_or(1.0);
            }
            out.push(r);
        }
        for residual in &program.residuals {
            let (a, b) = (
                value(values, &ones, residual.code),
                value(moved, &scale, residual.code),
            );
            out.push(ratio(a, b)?);
        }
        if let Some(copy) = &program.copy {
            for &rate in &copy.rates {
                let (a, b) = (value(values, &ones, rate), value(moved, &ones, rate));
                let same = (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1e-300)
                    || (a.is_nan() && b.is_nan());
                if !same {
                    return None;
                }
            }
        }
        Some(out)
    }
}

/// A number in [0, 1) from a xorshift state: the structural check's signals, the same on
/// every run.
fn uniform(state: &mut u64) -> f64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// The central difference of the weighted residuals between `up` and `down`, `h` either
/// side, over the rows of `base` (rows matched by their place; a row either lacks gives 0:
/// the generator found no number there).
fn difference(base: &Samples, up: &Samples, down: &Samples, h: f64) -> Vec<f64> {
    let n = base.residuals;
    let mut column = vec![0.0; base.values.len()];
    let (mut a, mut b) = (0, 0);
    for (i, at) in base.at.iter().enumerate() {
        while a < up.rows && up.at[a] < *at {
            a += 1;
        }
        while b < down.rows && down.at[b] < *at {
            b += 1;
        }
        if a < up.rows && up.at[a] == *at && b < down.rows && down.at[b] == *at {
            for k in 0..n {
                let d = up.values[a * n + k] - down.values[b * n + k];
                column[i * n + k] = d / (2.0 * h);
            }
        }
    }
    column
}

/// The normal equations of one iteration, on columns scaled to unit norm.
struct Normal {
    /// `Dᵀ JᵀJ D`, `D` the inverse column norms.
    normalised: Square,
    /// `D Jᵀr`.
    gradient: Vec<f64>,
    /// The inverse column norms (0 for a column of zeros).
    scale: Vec<f64>,
}

impl Normal {
    fn new(columns: &[Vec<f64>], base: &Samples) -> Normal {
        let n = columns.len();
        let weighted = &base.values;
        let norms: Vec<f64> = columns.iter().map(|c| dot(c, c).sqrt()).collect();
        let scale: Vec<f64> = norms
            .iter()
            .map(|&x| if x > 0.0 { 1.0 / x } else { 0.0 })
            .collect();
        let mut normalised = Square::zeros(n);
        for i in 0..n {
            for j in i..n {
                let v = dot(&columns[i], &columns[j]) * scale[i] * scale[j];
                normalised.a[i * n + j] = v;
                normalised.a[j * n + i] = v;
            }
        }
        let gradient = (columns.iter().zip(&scale))
            .map(|(c, s)| dot(c, weighted) * s)
            .collect();
        Normal {
            normalised,
            gradient,
            scale,
        }
    }

    /// The Levenberg–Marquardt step with `damping` (relative to the largest eigenvalue),
    /// in the directions the records determine only.
    fn step(&self, damping: f64) -> Vec<f64> {
        let (values, vectors) = eigen_symmetric(&self.normalised);
        let top = values.first().copied().unwrap_or(0.0);
        let mut step = vec![0.0; self.scale.len()];
        for (l, v) in values.iter().zip(&vectors) {
            if *l <= UNSEEN * top {
                continue;
            }
            let along = -dot(v, &self.gradient) / (l + damping * top);
            for (s, x) in step.iter_mut().zip(v) {
                *s += along * x;
            }
        }
        step.iter().zip(&self.scale).map(|(s, d)| s * d).collect()
    }

    /// The change of the log-scalings a change `score` of `Jᵀr` makes, to first order, in
    /// the directions the records determine: `−H⁺ score`.
    fn response(&self, score: &[f64]) -> Vec<f64> {
        let (values, vectors) = eigen_symmetric(&self.normalised);
        let top = values.first().copied().unwrap_or(0.0);
        let scaled: Vec<f64> = score.iter().zip(&self.scale).map(|(s, d)| s * d).collect();
        let mut out = vec![0.0; self.scale.len()];
        for (l, v) in values.iter().zip(&vectors) {
            if *l <= UNSEEN * top {
                continue;
            }
            let along = -dot(v, &scaled) / l;
            for (o, x) in out.iter_mut().zip(v) {
                *o += along * x;
            }
        }
        out.iter().zip(&self.scale).map(|(o, d)| o * d).collect()
    }

    /// `λmax / λmin` over the determined directions.
    fn condition(&self) -> f64 {
        let (values, _) = eigen_symmetric(&self.normalised);
        let top = values.first().copied().unwrap_or(0.0);
        let smallest = (values.iter().copied())
            .filter(|&l| l > UNSEEN * top)
            .fold(f64::INFINITY, f64::min);
        if smallest.is_finite() && smallest > 0.0 {
            top / smallest
        } else {
            f64::INFINITY
        }
    }

    /// The variance of each log-scaling: the diagonal of `H⁺ B H⁺`, `B` the covariance of
    /// the score from its sums over `batches`.
    fn sandwich(
        &self,
        columns: &[Vec<f64>],
        base: &Samples,
        batches: &[std::ops::Range<usize>],
    ) -> Vec<f64> {
        let n = columns.len();
        let r = base.residuals;
        let mut b = Square::zeros(n);
        for batch in batches {
            let mut score = vec![0.0; n];
            for i in batch.clone() {
                for k in 0..r {
                    let e = base.values[i * r + k];
                    for (s, c) in score.iter_mut().zip(columns) {
                        *s += e * c[i * r + k];
                    }
                }
            }
            let scaled: Vec<f64> = score.iter().zip(&self.scale).map(|(s, d)| s * d).collect();
            b.add_outer(&scaled, 1.0);
        }
        // H⁺ in the normalised coordinates, over the determined directions.
        let (values, vectors) = eigen_symmetric(&self.normalised);
        let top = values.first().copied().unwrap_or(0.0);
        let mut pinv = Square::zeros(n);
        for (l, v) in values.iter().zip(&vectors) {
            if *l > UNSEEN * top {
                pinv.add_outer(v, 1.0 / l);
            }
        }
        (0..n)
            .map(|j| {
                let row: Vec<f64> = (0..n).map(|i| pinv.at(j, i)).collect();
                let brow: Vec<f64> = (0..n)
                    .map(|i| (0..n).map(|m| b.at(i, m) * row[m]).sum())
                    .collect();
                dot(&row, &brow) * self.scale[j] * self.scale[j]
            })
            .collect()
    }
}

/// Student's t quantile at 0.975 for `dof` degrees of freedom (Cornish–Fisher expansion
/// about the normal's; within 1e-3 from 5 degrees on, conservative below).
fn student_975(dof: usize) -> f64 {
    let z: f64 = 1.959_963_984_540_054;
    let v = dof as f64;
    let z3 = z.powi(3);
    let z5 = z.powi(5);
    let z7 = z.powi(7);
    z + (z3 + z) / (4.0 * v)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v * v * v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn students_quantile_matches_its_table() {
        for (dof, t) in [
            (5, 2.571),
            (10, 2.228),
            (20, 2.086),
            (49, 2.010),
            (1000, 1.962),
        ] {
            assert!(
                (student_975(dof) - t).abs() < 5e-3,
                "{dof}: {}",
                student_975(dof)
            );
        }
    }

    #[test]
    fn windows_are_halved_to_odd_ones_the_estimator_can_still_fit() {
        let fit = |estimator, integration| Fit {
            step: 1e-3,
            estimator,
            integration,
        };
        let sg = |window| Estimator::SavitzkyGolay { window, degree: 3 };
        let halved = halve(&fit(sg(11), vec![Integration::Start]), 2).expect("halved");
        assert_eq!(halved.estimator, sg(5));
        // A residual past the list's end takes the default window, halved too.
        assert_eq!(
            halved.integration,
            [Integration::Start, Integration::Window(125)]
        );
        // Five samples cannot be halved under a cubic; an integration of one sample neither.
        let least = fit(sg(5), vec![Integration::Window(1)]);
        assert_eq!(halve(&least, 1), None);
    }

    #[test]
    fn intervals_are_widened_by_twice_the_move_of_the_halved_fit() {
        let estimate = |value: f64, determined| Estimate {
            parameter: 0,
            name: "M".into(),
            start: 90.0,
            value,
            std_error: 0.5,
            half_width: 1.0,
            determined,
            at_bound: false,
            signed: false,
        };
        let mut found = Identification {
            values: vec![93.5, 2.0],
            estimates: vec![
                estimate(93.5, Determined::Yes),
                estimate(2.0, Determined::Held),
            ],
            undetermined: Vec::new(),
            condition: 1.0,
            rms: Vec::new(),
            cost: (1.0, 1.0),
            samples: 100,
            batches: 5,
            stop: (Stop::Converged, 3),
            jumps: 0,
            left_out: 0,
            lost: Vec::new(),
            reach: Some(Reach {
                windows: (5, 125),
                values: vec![(0, 94.4), (1, 10.0)],
            }),
        };
        widen(&mut found);
        assert!((found.estimates[0].half_width - 2.8).abs() < 1e-12);
        // A held parameter keeps no interval to widen.
        assert_eq!(found.estimates[1].half_width, 1.0);
    }
}
