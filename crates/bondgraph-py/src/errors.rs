//! The exceptions the package raises, and diagnostics rendered as the CLI locates them.

use bondgraph_core::diagnostic::{Diagnostic, Diagnostics, LineIndex, Severity};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _native,
    BgcError,
    PyValueError,
    "Base of every error bgc raises."
);
create_exception!(
    _native,
    ModelError,
    BgcError,
    "A model with errors: `diagnostics` holds each, located."
);
create_exception!(
    _native,
    ScenarioError,
    BgcError,
    "A scenario with errors: `diagnostics` holds each, located."
);
create_exception!(
    _native,
    DataError,
    BgcError,
    "Samples that cannot be used: a missing or mistyped column, a bad step, a NaN."
);
create_exception!(
    _native,
    SimulationError,
    BgcError,
    "A simulation that could not go through."
);

/// One diagnostic as a line of text: `file:line:col: error[code]: message (label)`, then
/// its help.
fn render(file: &str, text: &str, lines: &LineIndex, d: &Diagnostic) -> String {
    let at = lines.line_col(text, d.span.start);
    let severity = match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    };
    let mut line = format!(
        "{file}:{}:{}: {severity}[{}]: {}",
        at.line,
        at.col,
        d.code.as_str(),
        d.message
    );
    if !d.label.is_empty() {
        line.push_str(&format!(" ({})", d.label));
    }
    if let Some(help) = &d.help {
        line.push_str(&format!("\n  help: {help}"));
    }
    line
}

/// The diagnostics as Python dicts: file, line, column, severity, code, message, label,
/// help.
pub(crate) fn as_dicts<'py>(
    py: Python<'py>,
    file: &str,
    text: &str,
    diagnostics: &Diagnostics,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let lines = LineIndex::new(text);
    diagnostics
        .iter()
        .map(|d| {
            let at = lines.line_col(text, d.span.start);
            let out = PyDict::new(py);
            out.set_item("file", file)?;
            out.set_item("line", at.line)?;
            out.set_item("column", at.col)?;
            out.set_item("severity", if d.is_error() { "error" } else { "warning" })?;
            out.set_item("code", d.code.as_str())?;
            out.set_item("message", &d.message)?;
            out.set_item("label", &d.label)?;
            out.set_item("help", d.help.as_deref())?;
            Ok(out)
        })
        .collect()
}

/// The exception `E` for `diagnostics` of `file`: its message every error, located, and its
/// `diagnostics` attribute each as a dict.
pub(crate) fn located<E: pyo3::PyTypeInfo>(
    py: Python<'_>,
    file: &str,
    text: &str,
    diagnostics: &Diagnostics,
) -> PyErr {
    let lines = LineIndex::new(text);
    let errors: Vec<String> = diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| render(file, text, &lines, d))
        .collect();
    let message = match errors.len() {
        1 => errors.join(""),
        n => format!("{n} errors:\n{}", errors.join("\n")),
    };
    let err = PyErr::from_type(py.get_type::<E>(), message);
    if let Ok(dicts) = as_dicts(py, file, text, diagnostics) {
        // An attribute the exception always has: a failure to set it leaves the message.
        let _ = err.value(py).setattr("diagnostics", dicts);
    }
    err
}

/// A [`DataError`] saying `message`.
pub(crate) fn data(message: impl Into<String>) -> PyErr {
    DataError::new_err(message.into())
}
