//! Which error the fit minimises.
//!
//! - The **equation error**: the ARRs' residuals. Fast, it needs no initial state and holds
//!   on any stretch of a record, but it reads derivatives (or integrals) of measured signals,
//!   whose estimates a smoother biases where a record has few samples per period of what
//!   moves, and whose noise a parameter that multiplies them lets in.
//! - The **simulation error** (output error): each sensor's reading against a copy of the
//!   model that the recorded inputs drive, from rest. No derivative of a measurement is
//!   read, so nothing biases it but the model itself; it is the figure the
//!   system-identification benchmarks publish. It needs a record that starts as the copy
//!   does (at rest) and a copy whose errors do not grow without bound, and each of its
//!   evaluations runs the copy over the whole record.
//! - **By evidence**: both fitted on the head of the records, and the one whose simulation
//!   error is lower on the held-out tail (simulated from each record's start) is fitted
//!   again on the whole records.

use bondgraph_core::program::{Program, Stability};
use bondgraph_core::Compiled;

use super::{identify, Identification, IdentifyError, Record, Settings};
use crate::fit::{Estimator, Integration};
use crate::generator::Generator;

/// Which error the fit minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Criterion {
    /// The ARRs' residuals.
    Equation,
    /// Each sensor against a copy of the model the recorded inputs drive.
    Simulation,
    /// Whichever of the two predicts a held-out tail of the records better.
    Evidence,
}

/// The share of each record held out to choose a criterion by evidence.
pub const HELD_OUT: f64 = 0.3;

/// A model as each criterion reads it: its equation-error program and, where a copy of the
/// model can run on the records, its simulation-error one (compiled with
/// `ResidualSet::Simulated`).
pub struct Criteria<'a> {
    /// The model and its ARRs' program.
    pub equation: (&'a Compiled, &'a Program),
    /// The model compiled for its simulated residuals, and their program; `None` where the
    /// model has none (see [`Criteria::simulation_missing`]).
    pub simulation: Option<(&'a Compiled, &'a Program)>,
}

/// What chose the criterion, where it was chosen by evidence.
#[derive(Clone, Debug, PartialEq)]
pub struct Evidence {
    /// The share of each record held out.
    pub held_out: f64,
    /// The simulation error (RMS per sensor, over the held-out tails) of the equation-error
    /// fit on the heads.
    pub equation: Vec<f64>,
    /// The same of the simulation-error fit.
    pub simulation: Vec<f64>,
}

/// The criterion a fit used, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Chosen {
    /// [`Criterion::Equation`] or [`Criterion::Simulation`].
    pub criterion: Criterion,
    /// The held-out comparison, where the choice was made by evidence and both fits could
    /// be made.
    pub evidence: Option<Evidence>,
    /// Why the equation error was used where the simulation error was asked for or
    /// weighed: the copy cannot run, or its fit failed.
    pub fallback: Option<String>,
}

impl Criteria<'_> {
    /// Why there is no simulation error to fit, where there is none.
    pub fn simulation_missing(&self) -> Option<&'static str> {
        match self.simulation {
            Some((c, _)) if !c.arrs.is_empty() => None,
            _ => Some(
                "the model has no simulated residual (its state equations are implicit, \
                 incomplete or read an input's derivative, so a copy of it cannot run on \
                 recorded inputs; or its detectors times its equations pass 2e7)",
            ),
        }
    }
}

/// Fits the parameters by `criterion` from `start`; `records` are in the equation
/// program's raw order (the simulation program's columns are found by name).
pub fn identify_by(
    criteria: &Criteria<'_>,
    start: &[f64],
    records: &[Record<'_>],
    settings: &Settings,
    criterion: Criterion,
) -> Result<(Identification, Chosen), IdentifyError> {
    let (c, program) = criteria.equation;
    let equation = |records: &[Record<'_>]| identify(c, program, start, records, settings);
    let simulated = match (criteria.simulation_missing(), criteria.simulation) {
        (None, Some((sc, sp))) => match reorder(program, sp) {
            Some(columns) => Ok((sc, sp, columns)),
            None => Err("the records lack a signal the copy of the model reads".to_string()),
        },
        (why, _) => Err(why.unwrap_or_default().to_string()),
    };
    let fallback = |why: String| Chosen {
        criterion: Criterion::Equation,
        evidence: None,
        fallback: Some(why),
    };
    let chosen = |criterion, evidence| Chosen {
        criterion,
        evidence,
        fallback: None,
    };
    match (criterion, simulated) {
        (Criterion::Equation, _) => Ok((equation(records)?, chosen(Criterion::Equation, None))),
        (_, Err(why)) => Ok((equation(records)?, fallback(why))),
        (Criterion::Simulation, Ok((sc, sp, columns))) => {
            let views = views(records, &columns);
            let settings = simulation_settings(settings, sc, sp);
            match identify(sc, sp, start, &views, &settings) {
                Ok(found) => Ok((found, chosen(Criterion::Simulation, None))),
                Err(e) => Ok((
                    equation(records)?,
                    fallback(format!("the simulation-error fit could not be made: {e}")),
                )),
            }
        }
        (Criterion::Evidence, Ok((_, sp, _))) if drifts(sp, start) => Ok((
            equation(records)?,
            fallback(
                "the copy of the model does not forget its start (linearised at rest, a mode \
                 does not decay: a free inertia's position, an integrator), so its simulation \
                 error drifts with any error of the model or of the inputs, and weighs that \
                 drift rather than the parameters"
                    .to_string(),
            ),
        )),
        (Criterion::Evidence, Ok((sc, sp, columns))) => {
            let views = views(records, &columns);
            let sim_settings = simulation_settings(settings, sc, sp);
            let heads: Vec<Record<'_>> = (records.iter())
                .map(|r| r.head(split(r.time.len())))
                .collect();
            let sim_heads: Vec<Record<'_>> = (views.iter())
                .map(|r| r.head(split(r.time.len())))
                .collect();
            // The heads are shorter than the records: their integration windows shrink as a
            // short record's do, where the records' do not fit them.
            let rows = heads.iter().map(|r| r.time.len()).min().unwrap_or(0);
            let (room, _) = super::integration_window_for(rows, settings.fit.estimator.window());
            let mut head_settings = settings.clone();
            for i in &mut head_settings.fit.integration {
                if let Integration::Window(n) = i {
                    *n = (*n).min(room);
                }
            }
            let by_equation = match identify(c, program, start, &heads, &head_settings) {
                Ok(found) => found,
                Err(e) => {
                    return Ok((
                        equation(records)?,
                        fallback(format!("no tail of the records could be held out: {e}")),
                    ))
                }
            };
            let by_simulation = match identify(sc, sp, start, &sim_heads, &sim_settings) {
                Ok(found) => found,
                Err(e) => {
                    return Ok((
                        equation(records)?,
                        fallback(format!("the simulation-error fit could not be made: {e}")),
                    ))
                }
            };
            let tail = |values: &[f64]| held_out_error(sc, sp, values, &views, &sim_settings);
            let evidence = Evidence {
                held_out: HELD_OUT,
                equation: tail(&by_equation.values),
                simulation: tail(&by_simulation.values),
            };
            let total = |e: &[f64]| e.iter().map(|x| x * x).sum::<f64>();
            // A non-finite error (a copy that ran away) loses; a tie goes to the equation
            // error, the cheaper and the one that needs no initial state.
            let simulation_wins = total(&evidence.simulation) < total(&evidence.equation)
                || (!total(&evidence.equation).is_finite()
                    && total(&evidence.simulation).is_finite());
            if simulation_wins {
                let found = identify(sc, sp, start, &views, &sim_settings)?;
                Ok((found, chosen(Criterion::Simulation, Some(evidence))))
            } else {
                Ok((
                    equation(records)?,
                    chosen(Criterion::Equation, Some(evidence)),
                ))
            }
        }
    }
}

/// Whether the copy's error in its start stays or grows (at the values `start`): its
/// simulation error is then no measure of the parameters to choose a criterion by.
fn drifts(program: &Program, start: &[f64]) -> bool {
    program.copy_stability(start) == Some(Stability::Persists)
}

/// The samples of a record's head that a choice by evidence fits.
fn split(rows: usize) -> usize {
    ((rows as f64) * (1.0 - HELD_OUT)).round() as usize
}

/// Each simulated residual's RMS over the held-out tails of `records` (simulated from each
/// record's start) with the parameters `values`; infinite where one is not a number.
fn held_out_error(
    c: &Compiled,
    program: &Program,
    values: &[f64],
    records: &[Record<'_>],
    settings: &Settings,
) -> Vec<f64> {
    let from: Vec<usize> = records.iter().map(|r| split(r.time.len())).collect();
    simulation_error(c, program, values, records, &from, settings)
}

/// Each simulated residual's RMS over the samples of each record from `from[k]` on, the copy
/// run from the record's start with the parameters `values` (as finely as the record needs:
/// see `substeps`): the simulation error.
/// Infinite where a residual is not a number somewhere there, or where the generator cannot
/// be built.
pub fn simulation_error(
    c: &Compiled,
    program: &Program,
    values: &[f64],
    records: &[Record<'_>],
    from: &[usize],
    settings: &Settings,
) -> Vec<f64> {
    let settings = &simulation_settings(settings, c, program);
    let n = program.residuals.len();
    let mut sums = vec![0.0; n];
    let mut count = 0usize;
    let substeps = records.first().map_or(1, |r| {
        super::substeps::substeps(c, program, values, (r.time, &r.raw), &settings.fit)
    });
    for (record, &first) in records.iter().zip(from) {
        let Ok(generator) = Generator::new(c, program, values, &settings.fit) else {
            return vec![f64::INFINITY; n];
        };
        let mut generator = generator.with_substeps(substeps);
        let after = record.time.get(first).copied().unwrap_or(f64::INFINITY);
        generator.run(record.time, &record.raw, false, |estimates| {
            for (i, &at) in estimates.at().iter().enumerate() {
                if at < after {
                    continue;
                }
                for (k, s) in sums.iter_mut().enumerate() {
                    let r = estimates.residual(k)[i];
                    *s += if r.is_finite() { r * r } else { f64::INFINITY };
                }
                count += 1;
            }
        });
    }
    (sums.into_iter())
        .map(|s| {
            if count == 0 {
                f64::INFINITY
            } else {
                (s / count as f64).sqrt()
            }
        })
        .collect()
}

/// The settings of a simulation-error fit: each sensor read as sampled (a smoother over
/// a window would attenuate what the copy follows: at 9 samples per period, a window of 11
/// takes most of a resonance away), and one integration per residual (none is integrated,
/// but the settings name one per residual).
fn simulation_settings(settings: &Settings, c: &Compiled, program: &Program) -> Settings {
    let mut s = settings.clone();
    if program.top_order() == 0 {
        s.fit.estimator = Estimator::SavitzkyGolay {
            window: 1,
            degree: 0,
        };
    }
    let first = s.fit.integration.first().copied().unwrap_or_default();
    s.fit.integration = vec![first; c.arrs.len()];
    if s.fit.integration.is_empty() {
        s.fit.integration.push(Integration::default());
    }
    s
}

/// For each raw signal of `to`, its column in `from`'s raw order; `None` where `from` lacks
/// one.
fn reorder(from: &Program, to: &Program) -> Option<Vec<usize>> {
    let names: Vec<&str> = from.raw.values().map(|r| r.name.as_str()).collect();
    (to.raw.values())
        .map(|r| names.iter().position(|&n| n == r.name))
        .collect()
}

/// The records with their columns in another program's raw order.
fn views<'a>(records: &[Record<'a>], columns: &[usize]) -> Vec<Record<'a>> {
    (records.iter())
        .map(|r| Record {
            time: r.time,
            raw: columns.iter().map(|&k| r.raw[k]).collect(),
            // Another program's: from rest.
            state: None,
        })
        .collect()
}

/// The model's outputs simulated on a record's inputs: each simulated residual's output
/// `ŷ` at every sample, the copy run from rest with the parameters `values` and stepped as
/// finely as the record needs. `record`'s columns are in `program`'s raw order (a simulated
/// residuals' program); a sensor's column may hold anything (zeros where the record has no
/// such column): the copy never reads a sensor, and `ŷ = y − r`.
pub fn simulate_record(
    c: &Compiled,
    program: &Program,
    values: &[f64],
    record: &Record<'_>,
    step: f64,
) -> Result<Vec<Vec<f64>>, IdentifyError> {
    let settings = Settings {
        fit: crate::fit::Fit {
            step,
            estimator: Estimator::SavitzkyGolay {
                window: 1,
                degree: 0,
            },
            integration: vec![Integration::default(); program.residuals.len()],
        },
        free: Vec::new(),
        bounded: false,
        span: None,
    };
    let settings = simulation_settings(&settings, c, program);
    let records = std::slice::from_ref(record);
    let substeps = records.first().map_or(1, |r| {
        super::substeps::substeps(c, program, values, (r.time, &r.raw), &settings.fit)
    });
    let generator = Generator::new(c, program, values, &settings.fit)
        .map_err(|e| IdentifyError::Estimator(e.to_string()))?;
    let mut generator = generator.with_substeps(substeps);
    // Each simulated residual's sensor, by its raw column.
    let sensors: Vec<Option<usize>> = (c.arrs.iter())
        .map(|a| {
            let name = c.sensors[a.sensor?].name.as_str();
            program.raw.values().position(|r| r.name == name)
        })
        .collect();
    let n = program.residuals.len();
    let mut out = vec![Vec::with_capacity(record.time.len()); n];
    let mut row = 0;
    generator.run(record.time, &record.raw, false, |estimates| {
        for i in 0..estimates.len() {
            for (k, o) in out.iter_mut().enumerate() {
                let y = sensors[k].map_or(0.0, |j| record.raw[j][row]);
                o.push(y - estimates.residual(k)[i]);
            }
            row += 1;
        }
    });
    Ok(out)
}
