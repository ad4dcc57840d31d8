//! `bondgraph_compiler._native`: the Rust side of the Python package. It compiles models,
//! writes what the CLI writes, runs the residual program over numpy columns, simulates and
//! verifies; the Python side (`python/bondgraph_compiler`) turns its plain results into
//! DataFrames, SymPy expressions and notebook displays.
//!
//! Nothing here panics on user input: every failure is a Python exception whose message
//! names the file, line and column as the CLI does.

mod errors;
mod fit;
mod model;
mod monitor;
mod records;
mod sim;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("BgcError", py.get_type::<errors::BgcError>())?;
    m.add("ModelError", py.get_type::<errors::ModelError>())?;
    m.add("ScenarioError", py.get_type::<errors::ScenarioError>())?;
    m.add("DataError", py.get_type::<errors::DataError>())?;
    m.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    m.add_class::<model::Model>()?;
    m.add_function(wrap_pyfunction!(model::compile, m)?)?;
    m.add_function(wrap_pyfunction!(model::sensors, m)?)?;
    m.add_function(wrap_pyfunction!(monitor::residuals, m)?)?;
    m.add_function(wrap_pyfunction!(fit::identify, m)?)?;
    m.add_function(wrap_pyfunction!(fit::with_values, m)?)?;
    m.add_function(wrap_pyfunction!(sim::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::verify, m)?)?;
    m.add_function(wrap_pyfunction!(records::read_columns, m)?)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
