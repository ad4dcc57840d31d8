//! `residuals`: the model's residual program run over numpy columns, with thresholds,
//! alarms and the components they point to, as `bgc residuals` computes them. One pass in
//! Rust with the interpreter's lock released; the columns are read where they lie.

use std::collections::HashMap;

use bondgraph::{Cusum, Episode, Signature, Threshold};
use bondgraph_interpreter::{
    beyond, beyond_said, calibrate, uniform_step, Calibrated, Calibration, Choices, Conditioning,
    CusumLevels, Estimates, Estimator, EstimatorKind, FalseAlarms, Fit, Generator, Hold, Holding,
    Integration, Range, Relations, Samples as CalibrationSamples, Singular, SizeOver, Sized,
    Sizing, StepError, Walk, SIZE_SAMPLES, STEP_TOLERANCE,
};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{self, BgcError};
use crate::model::Model;

/// How the estimates are made.
struct Settings {
    estimator: Estimator,
    integration: Vec<Integration>,
    thresholds: Vec<Option<f64>>,
    /// Per residual, the walk its threshold grows with (a kept calibration's).
    walks: Vec<Option<Walk>>,
    /// What tells where a record has settled and is singular (a calibration's).
    conditioning: Option<Conditioning>,
    /// Where the record is singular: no threshold there.
    singular: Singular,
    /// Each residual's CUSUM beside its threshold (a calibration's).
    cusum: Vec<Option<CusumLevels>>,
    debounce: u32,
    adaptive: bool,
    /// Each residual's memory, in samples (`Fit::memories`): what an episode waits for.
    memories: Vec<usize>,
    /// The parameters a calibration's fit found determined only together (by place).
    combined: Vec<Vec<usize>>,
    /// Each raw signal's range on the healthy record (a calibration's).
    ranges: Vec<Option<Range>>,
    /// Each integrated residual's hold (a calibration's), its integration then its onset
    /// window.
    holds: Vec<Option<Hold>>,
}

/// What one pass gives, flat, before it becomes numpy arrays.
struct Pass {
    at: Vec<f64>,
    /// Row by row, each residual's value and alarm.
    residuals: Vec<f64>,
    levels: Levels,
    alarms: Vec<bool>,
    /// Row by row, each held residual's hold and its threshold (see `Hold`).
    held: Vec<f64>,
    labels: Labels,
}

/// Each residual's threshold: where there is none, 0 (and `has_threshold` false: Python
/// marks it missing).
enum Levels {
    /// The same at every estimate, one per residual: numpy broadcasts the row.
    Fixed(Vec<f64>),
    /// Row by row, each residual's level with its bound from parameter uncertainty.
    Moving(Vec<f64>),
}

/// What the alarms of each estimate point to.
#[derive(Default)]
struct Labels {
    /// Per estimate, the index of its alarm pattern in `patterns`.
    pattern: Vec<u32>,
    patterns: Vec<Vec<bool>>,
    /// Per estimate, the index of the episode's candidates in `episodes` (0: no episode).
    episode: Vec<u32>,
    episodes: Vec<String>,
    /// Per estimate, 1 + the index of the root not found there (0: every root found).
    unsolved: Vec<u32>,
}

/// The step of `time` (its median interval, the stamps may jitter within the tolerance),
/// or why it has none.
fn step_of(time: &[f64]) -> PyResult<f64> {
    let step = uniform_step(time).map_err(|e| match e {
        StepError::TooFew(n) => errors::data(format!("{n} samples: too few to estimate anything")),
        StepError::NotIncreasing { row, from, to } => errors::data(format!(
            "row {row}: time goes from {from} to {to}: it must increase"
        )),
        StepError::Uneven { row, found, step } => errors::data(format!(
            "row {row}: a step of {found} s where the record's (its median interval) is {step} s, \
             {:.1} % off where {} % is accepted: the estimators need a uniform step",
            100.0 * (found - step).abs() / step,
            100.0 * STEP_TOLERANCE
        )),
    })?;
    Ok(step.step)
}

/// A record's time, its columns and its step.
pub(crate) type Samples<'a> = (&'a [f64], Vec<&'a [f64]>, f64);

/// The time and columns of a record handed from Python, checked: contiguous, as long as
/// the time, finite, at one step (within its tolerance); `labels` are the names the data
/// gives them, for the errors. With the step.
pub(crate) fn samples<'a>(
    names: &[&str],
    time: &'a PyReadonlyArray1<'_, f64>,
    columns: &'a [PyReadonlyArray1<'_, f64>],
    labels: Option<Vec<String>>,
) -> PyResult<Samples<'a>> {
    let time = time
        .as_slice()
        .map_err(|_| errors::data("the time column is not a contiguous, aligned array"))?;
    let mut data: Vec<&[f64]> = Vec::with_capacity(columns.len());
    for (column, name) in columns.iter().zip(names) {
        let slice = column.as_slice().map_err(|_| {
            errors::data(format!(
                "column `{name}` is not a contiguous, aligned array"
            ))
        })?;
        if slice.len() != time.len() {
            return Err(errors::data(format!(
                "column `{name}` has {} samples where time has {}",
                slice.len(),
                time.len()
            )));
        }
        data.push(slice);
    }
    // The names the data gives the time and the columns, for its errors.
    let labels = labels.unwrap_or_else(|| {
        std::iter::once("t")
            .chain(names.iter().copied())
            .map(String::from)
            .collect()
    });
    let label = |k: usize| labels.get(k).map_or("?", String::as_str);
    check_finite(label(0), time)?;
    for (k, column) in data.iter().enumerate() {
        check_finite(label(k + 1), column)?;
    }
    let step = step_of(time)?;
    Ok((time, data, step))
}

/// The first sample of a column that is not a finite number.
fn check_finite(name: &str, column: &[f64]) -> PyResult<()> {
    match column.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(errors::data(format!(
            "row {k}, column `{name}`: {} is not a finite number",
            column[k]
        ))),
        None => Ok(()),
    }
}

/// The kind of estimator a keyword names.
fn estimator_kind(kind: &str) -> PyResult<EstimatorKind> {
    match kind {
        "savitzky-golay" => Ok(EstimatorKind::SavitzkyGolay),
        "modulating" => Ok(EstimatorKind::Modulating),
        other => Err(PyValueError::new_err(format!(
            "estimator={other:?}: expected \"savitzky-golay\" or \"modulating\""
        ))),
    }
}

/// A healthy record to calibrate on, as Python hands it: its time, its columns (in the order
/// of `model.signals()`), their names in the data, the false alarms allowed (`"1/h"`, or a
/// share of samples), the margin, whether the model's values are kept, the drift of a
/// CUSUM beside each threshold (none without), and the seconds within which a fault should
/// show.
pub(crate) type Healthy<'py> = (
    PyReadonlyArray1<'py, f64>,
    Vec<PyReadonlyArray1<'py, f64>>,
    Option<Vec<String>>,
    String,
    f64,
    bool,
    Option<f64>,
    Option<f64>,
);

/// What the estimator, integration and thresholds are, as given (no healthy record).
fn given(
    kind: Option<EstimatorKind>,
    window: Option<usize>,
    degree: u32,
    integration: Option<Integration>,
    n: usize,
) -> (Estimator, Vec<Integration>) {
    let kind = kind.unwrap_or(EstimatorKind::SavitzkyGolay);
    let estimator = kind.over(window.unwrap_or(kind.default_window()), degree);
    (estimator, vec![integration.unwrap_or_default(); n])
}

/// Runs the residual program of `model` over the samples `columns` (in the order of
/// `model.signals()`) taken at `time`.
#[pyfunction]
#[pyo3(signature = (model, time, columns, *, thresholds, labels = None, window = None, estimator = None, degree = None, integration = None, debounce = 1, adaptive = false, size_span = Some(5.0), calibration = None, calibrate = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn residuals<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    time: PyReadonlyArray1<'py, f64>,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    thresholds: Vec<Option<f64>>,
    labels: Option<Vec<String>>,
    window: Option<usize>,
    estimator: Option<&str>,
    degree: Option<u32>,
    integration: Option<&str>,
    debounce: u32,
    adaptive: bool,
    size_span: Option<f64>,
    calibration: Option<(String, String, (String, String))>,
    calibrate: Option<Healthy<'py>>,
) -> PyResult<Bound<'py, PyDict>> {
    let c = &model.compiled;
    if size_span.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
        return Err(PyValueError::new_err(
            "size_span must be a positive number of seconds, or None",
        ));
    }
    if c.residual_code_refused() || c.arrs.is_empty() {
        return Err(BgcError::new_err(format!(
            "{}: no ARRs to evaluate (see the diagnostics)",
            model.file
        )));
    }
    let program = c.program();
    let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    if columns.len() != names.len() {
        return Err(errors::data(format!(
            "{} columns given; the residuals read {}: {}",
            columns.len(),
            names.len(),
            names.join(", ")
        )));
    }
    let (time, data, step) = samples(&names, &time, &columns, labels)?;
    if thresholds.len() != c.arrs.len() {
        return Err(PyValueError::new_err(format!(
            "{} thresholds for {} ARRs",
            thresholds.len(),
            c.arrs.len()
        )));
    }
    for (level, arr) in thresholds.iter().zip(&c.arrs) {
        if level.is_some_and(|l| !(l.is_finite() && l >= 0.0)) {
            return Err(PyValueError::new_err(format!(
                "the threshold of {} must be a finite number ≥ 0",
                arr.name
            )));
        }
    }
    let kind = estimator.map(estimator_kind).transpose()?;
    let degree = degree.unwrap_or(program.top_order().max(3));
    let integration = (integration.map(str::parse::<Integration>).transpose())
        .map_err(|e| PyValueError::new_err(format!("integration: {e}")))?;
    let (estimator, integrations) = given(kind, window, degree, integration, c.arrs.len());
    let mut settings = Settings {
        estimator,
        integration: integrations,
        thresholds,
        walks: vec![None; c.arrs.len()],
        conditioning: None,
        singular: Singular::default(),
        cusum: vec![None; c.arrs.len()],
        debounce,
        adaptive,
        memories: Vec::new(),
        combined: Vec::new(),
        ranges: Vec::new(),
        holds: vec![None; c.arrs.len()],
    };
    let mut params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let mut notes = Vec::new();
    if let Some((text, name, choice)) = &calibration {
        params = kept(&model, text, name, choice, (step, &names), &mut settings)?;
    }
    if let Some(healthy) = &calibrate {
        let choices = Choices {
            estimator: kind,
            window,
            degree,
            integration,
            share: 0.0,
            crossing: 0.0,
            margin: healthy.4,
            keep_model: healthy.5,
            thresholds: settings.thresholds.clone(),
            cusum: healthy.6,
            within: healthy.7,
        };
        let chosen = calibrated(py, c, &program, &params, healthy, step, choices)?;
        settings.estimator = chosen.estimator;
        settings.integration = chosen.integration;
        settings.thresholds = chosen.levels;
        settings.walks = chosen.walks;
        settings.conditioning = chosen.conditioning;
        settings.cusum = chosen.cusum;
        settings.combined = chosen.combined;
        settings.ranges = chosen.ranges;
        settings.holds = chosen.holds;
        params = chosen.params;
        notes = chosen.notes;
    }
    let window = match settings.estimator {
        Estimator::SavitzkyGolay { window, .. } | Estimator::Modulating { window } => window,
    };
    if time.len() < window {
        return Err(errors::data(format!(
            "{} samples: the estimator's window of {window} needs at least {window}",
            time.len()
        )));
    }
    if settings.debounce == 0 {
        return Err(PyValueError::new_err("debounce must be at least 1"));
    }
    let fit = Fit {
        step,
        estimator: settings.estimator,
        integration: settings.integration.clone(),
    };
    settings.memories = fit.memories(&c.arrs);
    // As the CLI: a held residual is evaluated from the start, its onset test and hold
    // reading that running integral.
    let running = Fit {
        integration: (settings.integration.iter().zip(&settings.holds))
            .map(|(&i, h)| if h.is_some() { Integration::Start } else { i })
            .collect(),
        ..fit.clone()
    };
    let generator = || {
        Generator::new(c, &program, &params, &fit).map_err(|e| PyValueError::new_err(e.to_string()))
    };
    // As the CLI: a record that starts unsettled has no threshold until it has settled
    // (its residuals evaluated from its start), nor where it is singular.
    if let Some(conditioning) = &settings.conditioning {
        let pair = (generator()?, generator()?);
        let (singular, first) =
            conditioning.undecided(&program, pair, time, &data, settings.estimator);
        if let Some(first) = first {
            notes.push(format!(
                "the record starts unsettled (signals the estimators' polynomials do not \
                 follow, a start-up): its first {first} samples, to {} s, have no threshold \
                 and raise no alarm",
                time[first]
            ));
        }
        settings.singular = singular;
    }
    let generator = Generator::new(c, &program, &params, &running)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let rows: Vec<(&str, Vec<u32>)> = (c.components.iter())
        .map(|(_, comp)| {
            let marks = comp
                .marks
                .iter()
                .map(|&k| u32::try_from(k).unwrap_or(u32::MAX));
            (comp.name.as_str(), marks.collect())
        })
        .collect();
    // The roots the residuals read, by slot: an estimate where one is not found names it.
    let roots: Vec<(usize, String)> = (program.slots.iter())
        .filter_map(|(h, s)| match s.quantity {
            bondgraph_core::Quantity::Root(r) => Some((h.index(), c.roots[r].name.clone())),
            _ => None,
        })
        .collect();
    let slots: Vec<usize> = roots.iter().map(|r| r.0).collect();
    let pass = py.detach(|| run(generator, time, &data, &settings, &rows, &slots));
    // As the CLI: a bank's sizes are fitted by its relations alone.
    let relations = Relations::of(c, &program);
    let (sized_by, sized_program, columns) = match &relations {
        Some(r) => (&r.compiled, &r.program, r.columns(&data)),
        None => (c, &program, data.to_vec()),
    };
    let sizing = Sizing::new(sized_by, sized_program, &params, time, columns, step);
    let lookahead = (window.saturating_sub(1) / 2) as f64 * step;
    let sized = match size_span {
        Some(span) => py.detach(|| sizes(&sizing, &pass, c.arrs.len(), lookahead, span)),
        None => Vec::new(),
    };
    // As the CLI says it: where the record goes beyond what calibration saw.
    let first_alarm = (pass.alarms.chunks(c.arrs.len().max(1)).zip(&pass.at))
        .find(|(on, _)| on.iter().any(|&a| a))
        .map(|(_, &t)| t);
    let found = beyond(&settings.ranges, &data);
    notes.extend(beyond_said(&names, &found, time, first_alarm));
    let has: Vec<bool> = settings.thresholds.iter().map(Option::is_some).collect();
    let outside = (settings.ranges.iter().any(Option::is_some))
        .then(|| outside(&settings.ranges, &names, (time, &data), &pass.at));
    let out = into_dict(py, pass, c.arrs.len(), &rows)?;
    if let Some((codes, sets)) = outside {
        out.set_item("beyond", PyArray1::from_vec(py, codes))?;
        out.set_item("beyond_names", sets)?;
    }
    out.set_item(
        "sizes",
        size_dicts(py, c, (&params, &settings.combined), &sized)?,
    )?;
    out.set_item("has_threshold", has)?;
    let held: Vec<&str> = (c.arrs.iter().zip(&settings.holds))
        .filter(|(_, h)| h.is_some())
        .map(|(a, _)| a.name.as_str())
        .collect();
    out.set_item("held", held)?;
    out.set_item("notes", notes)?;
    out.set_item("roots", roots.into_iter().map(|r| r.1).collect::<Vec<_>>())?;
    Ok(out)
}

/// Per estimate (at `at`), the raw signals whose sample there lies outside the healthy
/// record's range, as the CLI's `beyond` column names them: an index into the distinct
/// sets (space-separated names; the first, empty).
fn outside(
    ranges: &[Option<Range>],
    names: &[&str],
    (time, data): (&[f64], &[&[f64]]),
    at: &[f64],
) -> (Vec<u32>, Vec<String>) {
    let step = if time.len() > 1 {
        time[1] - time[0]
    } else {
        0.0
    };
    let mut sets: Vec<String> = vec![String::new()];
    let mut known: HashMap<String, u32> = HashMap::from([(String::new(), 0)]);
    let mut next = 0;
    let codes = (at.iter())
        .map(|&t| {
            while next + 1 < time.len() && time[next] < t - 0.25 * step {
                next += 1;
            }
            let set: Vec<&str> = (ranges.iter().zip(data).zip(names))
                .filter(|((range, column), _)| {
                    let x = column.get(next).copied().unwrap_or(f64::NAN);
                    range.is_some_and(|r| x.is_finite() && !r.holds(x))
                })
                .map(|(_, name)| *name)
                .collect();
            let set = set.join(" ");
            *known.entry(set.clone()).or_insert_with(|| {
                sets.push(set);
                index(sets.len() - 1)
            })
        })
        .collect();
    (codes, sets)
}

/// The calibration of `bgc residuals --calibrate` on the healthy record Python handed over
/// (see `bondgraph_interpreter::calibrate`), with the interpreter's lock released: the same
/// choices, thresholds and notes as the CLI's for the same record and options.
fn calibrated(
    py: Python<'_>,
    c: &bondgraph_core::Compiled,
    program: &bondgraph_core::program::Program,
    params: &[f64],
    healthy: &Healthy<'_>,
    step: f64,
    mut choices: Choices,
) -> PyResult<Calibrated> {
    let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    if healthy.1.len() != names.len() {
        return Err(errors::data(format!(
            "calibrate: {} columns given; the residuals read {}",
            healthy.1.len(),
            names.len()
        )));
    }
    let (time, columns, made) = samples(&names, &healthy.0, &healthy.1, healthy.2.clone())?;
    if (made - step).abs() > STEP_TOLERANCE * step {
        return Err(errors::data(format!(
            "calibrate: its step ({made} s) is not the record's ({step} s)"
        )));
    }
    let rate: FalseAlarms = (healthy.3.parse())
        .map_err(|e: String| PyValueError::new_err(format!("false_alarm_rate: {e}")))?;
    choices.share = rate.share();
    choices.crossing = rate.crossing(time.len() as f64 * made);
    let samples = CalibrationSamples {
        time,
        columns,
        step: made,
    };
    py.detach(|| calibrate(c, program, params, &samples, step, &choices))
        .map_err(|e| PyValueError::new_err(format!("calibrate: {e}")))
}

/// Applies a kept calibration (the text of a file `bgc residuals --calibrate ...
/// --save-calibration` wrote, named `name`) to `settings`, as `bgc residuals --calibration`
/// does: its estimator, integrations, walks and thresholds (a threshold given here wins);
/// with its parameter values; `raw`, the program's raw signals' names, for the ranges.
/// Refused for another model's text, other residuals (`choice`), another step or a wrong
/// line.
fn kept(
    model: &Model,
    text: &str,
    name: &str,
    choice: &(String, String),
    (step, raw): (f64, &[&str]),
    settings: &mut Settings,
) -> PyResult<Vec<f64>> {
    let c = &model.compiled;
    let refused = |what: String| errors::data(format!("{name}: {what}"));
    let kept = Calibration::parse(text).map_err(refused)?;
    let params: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    let arrs: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
    let choice = (choice.0.as_str(), choice.1.as_str());
    (kept.applies(model.text.as_bytes(), choice, &params, &arrs, step))
        .map_err(|e| refused(format!("{e} ({})", model.file)))?;
    settings.estimator = kept.estimator;
    settings.conditioning = kept.conditioning();
    settings.cusum = kept.decisions.iter().map(|d| d.cusum).collect();
    settings.combined = kept.combined_places();
    settings.ranges = kept.ranges_for(raw);
    for (k, d) in kept.decisions.iter().enumerate() {
        settings.integration[k] = d.integration.unwrap_or_default();
        // A level given here is the residual's only test.
        if settings.thresholds[k].is_none() {
            settings.thresholds[k] = d.threshold;
            settings.walks[k] = d.walk;
            settings.holds[k] = d.hold;
        }
    }
    Ok(kept.values())
}

/// The fault's size, as `bgc residuals` estimates it: once some residual alarms, each
/// candidate of the episode (as it stands at the record's end) with each of its parameters
/// fitted alone over `span` seconds from the first alarm's samples on, best fit first.
fn sizes(sizing: &Sizing<'_>, pass: &Pass, m: usize, lookahead: f64, span: f64) -> Vec<Sized> {
    let rows = || pass.alarms.chunks(m.max(1)).zip(&pass.at);
    let Some(begun) = rows().position(|(on, _)| on.iter().any(|&a| a)) else {
        return Vec::new();
    };
    let first = pass.at[begun];
    // As the CLI: an intermittent fault is sized over its first alarm, which ends where
    // the alarms stop for the samples a size needs.
    let mut lull: Option<(f64, usize)> = None;
    let mut quiet = None;
    for (on, &t) in rows().skip(begun) {
        lull = match (on.iter().any(|&a| a), lull) {
            (true, _) => None,
            (false, None) => Some((t, 1)),
            (false, Some((since, n))) => Some((since, n + 1)),
        };
        if let Some((since, SIZE_SAMPLES..)) = lull {
            quiet = Some(since - lookahead);
            break;
        }
    }
    let ranked: Vec<String> = (pass.labels.episodes.last())
        .map(|e| {
            e.split(' ')
                .filter(|c| !c.is_empty())
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default();
    let first = first + lookahead;
    let (span, quiet) = match sizing.over(quiet.map(|q| q - first), span) {
        SizeOver::Episode(alarm) => (sizing.span(alarm), quiet),
        SizeOver::Brief(_) => (span, None),
        SizeOver::Span => (span, quiet),
    };
    let end = (pass.at.last().copied().unwrap_or(first)).min(quiet.unwrap_or(f64::INFINITY));
    sizing.told(&ranked, first, span, end).0
}

/// The sizes as Python dicts: component, parameter, value, half-width, the ratio to the
/// model's value, the span and the fit's cost (residuals over their noise, mean square).
fn size_dicts<'py>(
    py: Python<'py>,
    c: &bondgraph_core::Compiled,
    (model, combined): (&[f64], &[Vec<usize>]),
    sized: &[Sized],
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let names: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    (sized.iter())
        .filter_map(|s| {
            let e = s
                .found
                .estimates
                .iter()
                .find(|e| e.parameter == s.parameter)?;
            Some((s, e))
        })
        .map(|(s, e)| {
            let d = PyDict::new(py);
            d.set_item("component", &s.component)?;
            d.set_item("parameter", names.get(s.parameter).copied().unwrap_or(""))?;
            d.set_item("value", e.value)?;
            d.set_item("half_width", e.half_width)?;
            let reference = model.get(s.parameter).copied().unwrap_or(0.0);
            d.set_item("model", reference)?;
            d.set_item("cost", s.found.cost.1)?;
            // The parameters it is determined only together with (calibration's fit): its
            // size is then a ratio only.
            let with: Vec<&str> = (combined.iter())
                .find(|places| places.contains(&s.parameter))
                .map(|places| {
                    (places.iter())
                        .filter(|&&k| k != s.parameter)
                        .filter_map(|&k| names.get(k).copied())
                        .collect()
                })
                .unwrap_or_default();
            d.set_item("determined_with", with)?;
            Ok(d)
        })
        .collect()
}

/// One pass over the samples.
fn run(
    mut generator: Generator,
    time: &[f64],
    data: &[&[f64]],
    settings: &Settings,
    rows: &[(&str, Vec<u32>)],
    roots: &[usize],
) -> Pass {
    let mut pass = Pass::reserved(time.len(), settings);
    let mut watch = Watch::new(settings, rows, roots);
    generator.run(time, data, settings.adaptive, |e| watch.block(&mut pass, e));
    pass
}

impl Pass {
    /// An empty pass with room for `n` estimates: at most one per sample, so that the
    /// outputs never move once reserved.
    fn reserved(n: usize, settings: &Settings) -> Pass {
        let m = settings.thresholds.len();
        let moving = settings.walks.iter().any(Option::is_some) || !settings.singular.is_empty();
        let levels = if settings.adaptive || moving {
            Levels::Moving(Vec::with_capacity(n * m))
        } else {
            Levels::Fixed(
                (settings.thresholds.iter())
                    .map(|l| l.unwrap_or(0.0))
                    .collect(),
            )
        };
        let labels = Labels {
            pattern: Vec::with_capacity(n),
            episode: Vec::with_capacity(n),
            // The first episode's index is 1: 0 is no episode.
            episodes: vec![String::new()],
            unsolved: Vec::with_capacity(n),
            ..Labels::default()
        };
        Pass {
            at: Vec::with_capacity(n),
            residuals: Vec::with_capacity(n * m),
            levels,
            alarms: Vec::with_capacity(n * m),
            held: Vec::new(),
            labels,
        }
    }
}

/// What the pass carries from one estimate to the next.
struct Watch<'a> {
    settings: &'a Settings,
    rows: &'a [(&'a str, Vec<u32>)],
    roots: &'a [usize],
    alarms: Vec<Option<Threshold>>,
    /// Each residual's CUSUM beside its threshold, where it has one.
    sequential: Vec<Option<Cusum>>,
    /// Each held residual's onset window and hold over its running integral.
    holding: Vec<Option<Holding>>,
    /// The last estimate's alarms, and its pattern's index.
    on: Vec<bool>,
    last: Option<usize>,
    known: HashMap<Vec<bool>, usize>,
    episode: Episode,
    /// The residuals the episode has seen in alarm, and whether it has begun.
    seen: Vec<bool>,
    began: bool,
}

impl<'a> Watch<'a> {
    /// Nothing seen yet: no alarm, no episode.
    fn new(settings: &'a Settings, rows: &'a [(&'a str, Vec<u32>)], roots: &'a [usize]) -> Self {
        let m = settings.thresholds.len();
        Watch {
            settings,
            rows,
            roots,
            alarms: (settings.thresholds.iter())
                .map(|l| l.map(|l| Threshold::new(l, settings.debounce)))
                .collect(),
            sequential: (settings.cusum.iter())
                .map(|c| c.map(|c| c.test()))
                .collect(),
            holding: (settings.holds.iter().zip(&settings.integration))
                .map(|(h, i)| {
                    let onset = match i {
                        Integration::Window(n) => *n,
                        Integration::Start => 1,
                    };
                    h.map(|h| Holding::new(h, onset))
                })
                .collect(),
            on: vec![false; m],
            last: None,
            known: HashMap::new(),
            episode: Episode::new(m).remembering(&settings.memories),
            seen: vec![false; m],
            began: false,
        }
    }
}

impl Watch<'_> {
    /// Takes a block of estimates into `pass`: each residual's values, levels and alarms,
    /// a residual at a time over the block, then what each estimate's alarms point to.
    fn block(&mut self, pass: &mut Pass, e: &Estimates<'_>) {
        let (len, m) = (e.len(), self.on.len());
        // The first estimate's index in the record, which a walk's deviation grows with.
        let first = pass.at.len();
        pass.at.extend_from_slice(e.at());
        let base = pass.residuals.len();
        pass.residuals.resize(base + len * m, 0.0);
        pass.alarms.resize(base + len * m, false);
        if let Levels::Moving(levels) = &mut pass.levels {
            levels.resize(base + len * m, 0.0);
        }
        // Each held residual's hold and threshold, two columns each, in the residuals' order.
        let h = 2 * self.holding.iter().flatten().count();
        let held_base = pass.held.len();
        pass.held.resize(held_base + len * h, f64::NAN);
        let mut slot = 0;
        let each = (self.alarms.iter_mut())
            .zip(&mut self.sequential)
            .zip(&self.settings.thresholds)
            .zip(&self.settings.walks)
            .zip(&mut self.holding);
        for (k, ((((alarm, sequential), level), walk), holding)) in each.enumerate() {
            for (j, (&running, &b)) in e.residual(k).iter().zip(e.bound(k)).enumerate() {
                let r = match holding.as_mut() {
                    Some(h) => h.onset(running),
                    None => running,
                };
                let at = base + j * m + k;
                // Where the relation is singular the noise decides it: no threshold.
                let singular = self.settings.singular.contains(k, e.at()[j]);
                let grown = |l: f64| walk.map_or(l, |w| w.threshold(l, first + j));
                let now = level.filter(|_| !singular).map(|l| grown(l) + b);
                // A bound that overflows (signals near the largest double) is no threshold.
                let overflowed = now.is_some_and(|l| !l.is_finite());
                let now = now.filter(|l| l.is_finite());
                // As the CLI leaves its cell empty: an overflowed residual is missing.
                pass.residuals[at] = if r.is_finite() { r } else { f64::NAN };
                if let Levels::Moving(levels) = &mut pass.levels {
                    levels[at] = now.unwrap_or(if singular || overflowed {
                        f64::NAN
                    } else {
                        0.0
                    });
                }
                // A residual that is not a number raises no alarm; its debounce goes on.
                pass.alarms[at] = match (alarm.as_mut(), now) {
                    (Some(a), Some(l)) if r.is_finite() => a.update_with_level(r, l),
                    _ => false,
                };
                if let Some(test) = sequential.as_mut().filter(|_| !singular) {
                    pass.alarms[at] |= test.update(r);
                }
                if let Some(hold) = holding.as_mut() {
                    let onset = pass.alarms[at];
                    pass.alarms[at] |= hold.update(running, first + j, onset, now.is_some());
                    let cell = held_base + j * h + slot;
                    pass.held[cell] = hold.value();
                    // As the CLI: no threshold where the onset test has none.
                    pass.held[cell + 1] = now.map_or(f64::NAN, |_| hold.threshold());
                }
            }
            if holding.is_some() {
                slot += 2;
            }
        }
        let rows = pass.alarms[base..].chunks_exact(m.max(1));
        for (on, &unsolved) in rows.zip(e.unsolved()) {
            self.follow(on, unsolved, &mut pass.labels);
        }
    }

    /// Takes one estimate's alarms `on`, and the slot of the root not found there, into
    /// `labels`: its pattern, and the episode's candidates.
    fn follow(&mut self, on: &[bool], unsolved: Option<usize>, labels: &mut Labels) {
        // Compared flag by flag: a few flags, where a slice comparison is a call.
        let same = self.last.is_some() && on.iter().zip(&self.on).all(|(a, b)| a == b);
        let code = match self.last {
            Some(code) if same => code,
            _ => {
                self.on.copy_from_slice(on);
                *self.known.entry(self.on.clone()).or_insert_with(|| {
                    labels.patterns.push(self.on.clone());
                    labels.patterns.len() - 1
                })
            }
        };
        self.last = Some(code);
        labels.pattern.push(index(code));
        self.episode.push(on);
        let mut episode_code = 0;
        if self.episode.started() {
            let moved = self.episode.update_seen(&mut self.seen);
            if moved || !self.began {
                self.began = true;
                let m = self.on.len();
                let fsm = (self.rows.iter()).map(|(name, s)| (*name, Signature::new(m, s)));
                labels.episodes.push(self.episode.candidates(fsm).join(" "));
            }
            episode_code = labels.episodes.len() - 1;
        }
        labels.episode.push(index(episode_code));
        let unsolved = unsolved.and_then(|slot| self.roots.iter().position(|&r| r == slot));
        labels.unsolved.push(unsolved.map_or(0, |i| index(i + 1)));
    }
}

/// An index into one of the pass's tables, as numpy stores it.
fn index(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

/// The pass as numpy arrays and tables.
fn into_dict<'py>(
    py: Python<'py>,
    pass: Pass,
    m: usize,
    rows: &[(&str, Vec<u32>)],
) -> PyResult<Bound<'py, PyDict>> {
    let n = pass.at.len();
    let fsm = || rows.iter().map(|(name, s)| (*name, Signature::new(m, s)));
    let candidates: Vec<String> = (pass.labels.patterns.iter())
        .map(|on| bondgraph::candidates(fsm(), on).join(" "))
        .collect();
    let suspects: Vec<String> = (pass.labels.patterns.iter())
        .map(|on| bondgraph::suspects(fsm(), on).join(" "))
        .collect();
    let out = PyDict::new(py);
    out.set_item("time", PyArray1::from_vec(py, pass.at))?;
    out.set_item(
        "residuals",
        PyArray1::from_vec(py, pass.residuals).reshape([n, m])?,
    )?;
    match pass.levels {
        Levels::Fixed(row) => out.set_item("thresholds", PyArray1::from_vec(py, row))?,
        Levels::Moving(levels) => out.set_item(
            "thresholds",
            PyArray1::from_vec(py, levels).reshape([n, m])?,
        )?,
    }
    out.set_item(
        "alarms",
        PyArray1::from_vec(py, pass.alarms).reshape([n, m])?,
    )?;
    let h = pass.held.len() / n.max(1);
    out.set_item("holds", PyArray1::from_vec(py, pass.held).reshape([n, h])?)?;
    out.set_item("pattern", PyArray1::from_vec(py, pass.labels.pattern))?;
    out.set_item("candidates", candidates)?;
    out.set_item("suspects", suspects)?;
    out.set_item("episode", PyArray1::from_vec(py, pass.labels.episode))?;
    out.set_item("episodes", pass.labels.episodes)?;
    out.set_item("unsolved", PyArray1::from_vec(py, pass.labels.unsolved))?;
    Ok(out)
}
