//! `compile` and the model it gives: what the CLI's emitters write, the signals its
//! residuals read, and the entry points of the numeric work.

use bondgraph_core::{Compiled, Derive, Limits, Options, Realise, ResidualSet};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::errors::{self, ModelError};

/// A compiled model: the product of `bgc MODEL`, with the text it was compiled from.
#[pyclass(frozen, module = "bondgraph_compiler._native")]
pub(crate) struct Model {
    pub(crate) compiled: Compiled,
    /// The model's text, for the diagnostics and `sensors`.
    pub(crate) text: String,
    /// The name diagnostics give the model's file.
    pub(crate) file: String,
}

/// The residual set a keyword names.
fn residual_set(name: &str) -> PyResult<ResidualSet> {
    match name {
        "per-sensor" => Ok(ResidualSet::PerSensor),
        "best" => Ok(ResidualSet::Best),
        "all" => Ok(ResidualSet::All),
        "simulated" => Ok(ResidualSet::Simulated),
        "partial" => Ok(ResidualSet::Partial),
        "bank" => Ok(ResidualSet::Bank),
        other => Err(PyValueError::new_err(format!(
            "residuals={other:?}: expected \"per-sensor\", \"best\", \"all\", \"simulated\", \
             \"partial\" or \"bank\""
        ))),
    }
}

/// The realisation a keyword names.
fn realise(name: &str) -> PyResult<Realise> {
    match name {
        "lowest" => Ok(Realise::Lowest),
        "direct" => Ok(Realise::Direct),
        other => Err(PyValueError::new_err(format!(
            "realise={other:?}: expected \"lowest\" or \"direct\""
        ))),
    }
}

/// Compiles the model `text`, named `file` in diagnostics, as `bgc FILE --residuals SET
/// --realise HOW` does; raises `ModelError` with every error located.
#[pyfunction]
#[pyo3(signature = (text, file, residuals = "per-sensor", realisation = "lowest"))]
pub(crate) fn compile(
    py: Python<'_>,
    text: &str,
    file: &str,
    residuals: &str,
    realisation: &str,
) -> PyResult<Model> {
    let options = Options {
        derive: Derive::Everything,
        simplify: Some(Limits::default()),
        residuals: residual_set(residuals)?,
        realise: realise(realisation)?,
    };
    let text = bondgraph_core::without_bom(text).to_string();
    let out = py
        .detach(|| bondgraph_core::compile(&text, file, &options))
        .map_err(|d| errors::located::<ModelError>(py, file, &text, &d))?;
    Ok(Model {
        compiled: out.compiled,
        text,
        file: file.to_string(),
    })
}

#[pymethods]
impl Model {
    /// The model as `bgc MODEL --emit json` writes it (`sparse`: `--fsm sparse`).
    #[pyo3(signature = (sparse = false))]
    fn json(&self, sparse: bool) -> String {
        let form = if sparse {
            bondgraph_codegen::json::FsmForm::Sparse
        } else {
            bondgraph_codegen::json::FsmForm::Dense
        };
        bondgraph_codegen::json::emit_with(&self.compiled, form)
    }

    /// The model as `bgc MODEL --emit TARGET` writes it: `text`, `latex`, `state`, `dot` or
    /// `rust` (`standalone`: a whole LaTeX document).
    #[pyo3(signature = (target, standalone = false))]
    fn emit(&self, target: &str, standalone: bool) -> PyResult<String> {
        let c = &self.compiled;
        Ok(match target {
            "text" => bondgraph_codegen::text::emit(c),
            "latex" => bondgraph_codegen::latex::emit(c, standalone),
            "state" => bondgraph_codegen::text::state(c),
            "dot" => bondgraph_codegen::dot::emit(c),
            "rust" if c.residual_code_refused() => {
                return Err(errors::BgcError::new_err(format!(
                    "{}: no residual code: the ARRs were refused (see the diagnostics)",
                    self.file
                )))
            }
            "rust" => bondgraph_codegen::rust::emit(c).map_err(|why| {
                errors::BgcError::new_err(format!("{}: cannot write Rust: {why}", self.file))
            })?,
            other => {
                return Err(PyValueError::new_err(format!(
                    "target={other:?}: expected \"text\", \"latex\", \"state\", \"dot\" or \"rust\""
                )))
            }
        })
    }

    /// The warnings the model compiled with, each a dict (file, line, column, severity,
    /// code, message, label, help).
    fn diagnostics<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, pyo3::types::PyDict>>> {
        errors::as_dicts(py, &self.file, &self.text, &self.compiled.diagnostics)
    }

    /// The signals the residuals read, in the order `residuals` takes its columns.
    fn signals(&self) -> Vec<String> {
        let program = self.compiled.program();
        program.raw.values().map(|r| r.name.clone()).collect()
    }

    /// The name of each ARR, in order.
    fn arr_names(&self) -> Vec<String> {
        self.compiled.arrs.iter().map(|a| a.name.clone()).collect()
    }

    /// The model's text.
    #[getter]
    fn text(&self) -> &str {
        &self.text
    }

    /// The name diagnostics give the model's file.
    #[getter]
    fn file(&self) -> &str {
        &self.file
    }
}

/// Fault classes as a dict: `classes` (lists of names) and `undetectable`.
fn classes<'py>(
    py: Python<'py>,
    k: &bondgraph_core::NamedClasses,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let out = pyo3::types::PyDict::new(py);
    out.set_item("classes", k.classes.clone())?;
    out.set_item("undetectable", k.undetectable.clone())?;
    Ok(out)
}

/// Where to add detectors so that `targets` (every component when empty) become
/// detectable (`goal="detectable"`) or as isolable as detectors can make them
/// (`"isolable"`), as `bgc sensors` answers.
#[pyfunction]
#[pyo3(signature = (model, targets, goal = "isolable"))]
pub(crate) fn sensors<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    targets: Vec<String>,
    goal: &str,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let goal = match goal {
        "detectable" => bondgraph_core::Goal::Detectable,
        "isolable" => bondgraph_core::Goal::Isolable,
        other => {
            return Err(PyValueError::new_err(format!(
                "goal={other:?}: expected \"detectable\" or \"isolable\""
            )))
        }
    };
    let text = &model.text;
    let placement = py
        .detach(|| bondgraph_core::place_sensors(text, &targets, goal))
        .map_err(|d| errors::located::<ModelError>(py, &model.file, text, &d))?
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let out = pyo3::types::PyDict::new(py);
    out.set_item("targets", placement.targets.clone())?;
    out.set_item("reached", placement.reached)?;
    out.set_item("exhaustive", placement.exhaustive)?;
    out.set_item("now", classes(py, &placement.now)?)?;
    out.set_item("most", classes(py, &placement.most)?)?;
    let proposals: Vec<Bound<'py, pyo3::types::PyDict>> = (placement.proposals.iter())
        .map(|p| {
            let d = pyo3::types::PyDict::new(py);
            let detectors: Vec<(&str, &str)> = (p.detectors.iter())
                .map(|n| (n.kind, n.junction.as_str()))
                .collect();
            d.set_item("detectors", detectors)?;
            d.set_item("classes", classes(py, &p.classes)?)?;
            Ok(d)
        })
        .collect::<PyResult<_>>()?;
    out.set_item("proposals", proposals)?;
    Ok(out)
}
