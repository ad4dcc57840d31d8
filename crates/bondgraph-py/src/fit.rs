//! `identify` and `with_values`: the model's parameters fitted to healthy records, as `bgc
//! identify` fits them, and a model's text with values of the caller's in place of its own.

use bondgraph_core::{Compiled, Derive, Limits, Options, ParameterValues, Realise, ResidualSet};
use bondgraph_interpreter::{
    choose_free, identify_by, Criteria, Criterion, Determined, Estimator, Fit, Integration, Origin,
    Record, Settings, Span, Stop,
};
use numpy::PyReadonlyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors::{self, BgcError};
use crate::model::Model;
use crate::monitor::samples;

/// The span a fault is sized over, `(from, to)` seconds, checked.
fn span_of(span: Option<(f64, f64)>) -> PyResult<Option<Span>> {
    match span {
        None => Ok(None),
        Some((from, to)) if from.is_finite() && to.is_finite() && from < to => Ok(Some(Span {
            from,
            to,
            origin: Origin::Span,
        })),
        Some((from, to)) => Err(PyValueError::new_err(format!(
            "span = ({from}, {to}): expected (from, to) seconds with from < to"
        ))),
    }
}

/// Fits the parameters of `model` to one healthy record (`columns` in the order of
/// `model.signals()`, taken at `time`), as `bgc identify` does; a dict of the estimates,
/// their intervals and the combinations the record does not determine.
#[pyfunction]
#[pyo3(signature = (model, time, columns, *, labels = None, window = 51, integration = 250, only = None, fix = None, span = None, criterion = "evidence"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn identify<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    time: PyReadonlyArray1<'py, f64>,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    labels: Option<Vec<String>>,
    window: usize,
    integration: usize,
    only: Option<Vec<String>>,
    fix: Option<Vec<String>>,
    span: Option<(f64, f64)>,
    criterion: &str,
) -> PyResult<Bound<'py, PyDict>> {
    // A fault's size over a span is the equation error's business (the copy would have to
    // start at the span).
    let criterion = match criterion_of(criterion)? {
        _ if span.is_some() => Criterion::Equation,
        c => c,
    };
    let c = &model.compiled;
    if c.residual_code_refused() || c.arrs.is_empty() {
        return Err(BgcError::new_err(format!(
            "{}: no ARRs to fit the parameters to (see the diagnostics)",
            model.file
        )));
    }
    let program = c.program();
    let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    let (time, data, step) = samples(&names, &time, &columns, labels)?;
    let settings = Settings {
        fit: Fit {
            step,
            estimator: Estimator::SavitzkyGolay {
                window,
                degree: program.top_order().max(3),
            },
            integration: vec![Integration::Window(integration.max(1)); c.arrs.len()],
        },
        free: choose_free(
            c,
            only.as_deref().unwrap_or_default(),
            fix.as_deref().unwrap_or_default(),
        )
        .map_err(PyValueError::new_err)?,
        bounded: false,
        span: span_of(span)?,
    };
    let start: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let record = [Record {
        time,
        raw: data,
        state: None,
    }];
    let simulated = (criterion != Criterion::Equation)
        .then(|| simulated_model(&model))
        .flatten();
    let simulated_program = simulated.as_ref().map(Compiled::program);
    let criteria = Criteria {
        equation: (c, &program),
        simulation: simulated.as_ref().zip(simulated_program.as_ref()),
    };
    let (found, chosen) = py
        .detach(|| identify_by(&criteria, &start, &record, &settings, criterion))
        .map_err(|e| errors::data(format!("{}: {e}", model.file)))?;
    let out = PyDict::new(py);
    let estimates = PyList::empty(py);
    for e in &found.estimates {
        let row = PyDict::new(py);
        row.set_item("name", &e.name)?;
        row.set_item("model", e.start)?;
        row.set_item("value", e.value)?;
        row.set_item("half_width", e.half_width)?;
        row.set_item("std_error", e.std_error)?;
        // Where the fit with the estimators' windows halved took it (its move, twice over,
        // is in the half-width); None where no window was halved.
        let halved = (found.reach.iter())
            .flat_map(|r| &r.values)
            .find(|(k, _)| *k == e.parameter)
            .map(|&(_, v)| v);
        row.set_item("halved_windows", halved)?;
        row.set_item("determined", determined(&e.determined))?;
        estimates.append(row)?;
    }
    out.set_item("estimates", estimates)?;
    let undetermined = PyList::empty(py);
    for combination in &found.undetermined {
        let row = PyDict::new(py);
        let scalings = PyDict::new(py);
        for &(k, x) in &combination.scalings {
            scalings.set_item(&found.estimates[k].name, x)?;
        }
        row.set_item("scalings", scalings)?;
        row.set_item("structural", combination.structural)?;
        undetermined.append(row)?;
    }
    out.set_item("undetermined", undetermined)?;
    out.set_item("condition", found.condition)?;
    out.set_item("rms", found.rms.clone())?;
    out.set_item("samples", found.samples)?;
    out.set_item("batches", found.batches)?;
    out.set_item("converged", found.stop.0 == Stop::Converged)?;
    out.set_item(
        "criterion",
        match chosen.criterion {
            Criterion::Simulation => "simulation",
            _ => "equation",
        },
    )?;
    out.set_item("criterion_note", chosen.fallback.clone())?;
    out.set_item("cost", found.cost)?;
    let lost = PyList::empty(py);
    for l in &found.lost {
        lost.append((&l.name, l.towards))?;
    }
    out.set_item("lost", lost)?;
    out.set_item("iterations", found.stop.1)?;
    Ok(out)
}

/// What a parameter's determination is called in Python.
fn determined(d: &Determined) -> &'static str {
    match d {
        Determined::Yes => "yes",
        Determined::Weakly => "weakly",
        Determined::No => "combination",
        Determined::Unread => "unread",
        Determined::Held => "held",
        Determined::Lost => "lost",
    }
}

/// The criterion a keyword names.
fn criterion_of(name: &str) -> PyResult<Criterion> {
    match name {
        "equation" => Ok(Criterion::Equation),
        "simulation" => Ok(Criterion::Simulation),
        "evidence" => Ok(Criterion::Evidence),
        other => Err(PyValueError::new_err(format!(
            "criterion={other:?}: expected \"equation\", \"simulation\" or \"evidence\""
        ))),
    }
}

/// The model compiled for its simulated residuals (the output error); `None` where it has
/// none.
fn simulated_model(model: &Model) -> Option<Compiled> {
    let options = Options {
        derive: Derive::Everything,
        simplify: Some(Limits::default()),
        residuals: ResidualSet::Simulated,
        realise: Realise::default(),
    };
    let out = bondgraph_core::compile(&model.text, &model.file, &options).ok()?;
    (!out.compiled.arrs.is_empty()).then_some(out.compiled)
}

/// The model `text` with the values `values` (name → value) in place of its own, the rest
/// of the text as it was; a name the model does not declare raises `ValueError`.
#[pyfunction]
pub(crate) fn with_values(text: &str, values: Vec<(String, f64)>) -> PyResult<String> {
    if let Some((name, _)) = values.iter().find(|(_, v)| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "the value of `{name}` must be a finite number"
        )));
    }
    ParameterValues::from_pairs(values)
        .apply(text)
        .map_err(|e| PyValueError::new_err(e.message))
}
