//! `simulate` and `verify`: the model integrated under a scenario, and its ARRs and FSM
//! checked on simulated trajectories, as `bgc simulate` and `bgc verify` do.

use bondgraph_sim::{parse_scenario, Simulation, VerifyOptions};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{self, ScenarioError, SimulationError};
use crate::model::Model;

/// The model run under the scenario `text` (the language of `bgc simulate`): the column
/// names (`t`, the inputs, the states, the measured signals) and the samples, a row each.
#[pyfunction]
#[pyo3(signature = (model, text, file = "<scenario>"))]
pub(crate) fn simulate<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    text: &str,
    file: &str,
) -> PyResult<(Vec<String>, Bound<'py, PyAny>)> {
    let (scenario, diagnostics) = parse_scenario(text);
    let scenario =
        scenario.ok_or_else(|| errors::located::<ScenarioError>(py, file, text, &diagnostics))?;
    let simulation = Simulation::new(&model.compiled, &scenario)
        .map_err(|d| errors::located::<ScenarioError>(py, file, text, &d))?;
    let trajectory = py.detach(|| simulation.run(|_| {})).map_err(|e| {
        // Where the cause is written in the scenario (an input with no value), it is located.
        match simulation.locate(&e) {
            Some(span) => {
                let mut d = bondgraph_core::diagnostic::Diagnostics::default();
                d.push(bondgraph_core::diagnostic::Diagnostic::error(
                    bondgraph_core::diagnostic::Code::BadValue,
                    span,
                    e.to_string(),
                ));
                errors::located::<SimulationError>(py, file, text, &d)
            }
            None => SimulationError::new_err(format!("{}: {e}", model.file)),
        }
    })?;
    let rows = trajectory.values.first().map_or(0, Vec::len);
    let columns = trajectory.columns.len();
    let mut flat = Vec::with_capacity(rows * columns);
    for k in 0..rows {
        flat.extend(trajectory.values.iter().map(|c| c[k]));
    }
    let samples = PyArray1::from_vec(py, flat).reshape([rows, columns])?;
    Ok((trajectory.columns, samples.into_any()))
}

/// Checks every ARR and FSM entry numerically, as `bgc verify` does: each ARR on the
/// healthy plant, each entry under a fault of its component.
#[pyfunction]
#[pyo3(signature = (model, *, input_scale = 1.0, state_scale = 0.5, runs = 3))]
pub(crate) fn verify<'py>(
    py: Python<'py>,
    model: PyRef<'py, Model>,
    input_scale: f64,
    state_scale: f64,
    runs: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let options = VerifyOptions {
        input_scale,
        state_scale,
        runs,
        ..VerifyOptions::default()
    };
    options
        .check()
        .map_err(pyo3::exceptions::PyValueError::new_err)?;
    let c = &model.compiled;
    let v = py
        .detach(|| bondgraph_sim::verify(c, &options))
        .map_err(|e| SimulationError::new_err(format!("{}: {e}", model.file)))?;
    let arrs: Vec<(String, f64, bool)> = (v.arrs.iter())
        .map(|a| (a.name.clone(), a.worst, a.pass))
        .collect();
    let entries: Vec<(String, String, bool, f64, bool)> = (v.entries.iter())
        .map(|e| {
            (
                c.components[e.component].name.clone(),
                c.arrs[e.arr].name.clone(),
                e.marked,
                e.worst,
                e.pass,
            )
        })
        .collect();
    let unchecked: Vec<String> = (v.unchecked.iter())
        .map(|&h| c.components[h].name.clone())
        .collect();
    let out = PyDict::new(py);
    out.set_item("arrs", arrs)?;
    out.set_item("entries", entries)?;
    out.set_item("unchecked", unchecked)?;
    out.set_item("step", v.step)?;
    out.set_item("state_scale", v.state_scale)?;
    let jumps: Vec<(String, f64)> = (v.arrs.iter())
        .filter_map(|a| Some((a.name.clone(), a.jump?)))
        .collect();
    out.set_item("jumps", jumps)?;
    out.set_item("crossings", v.crossings.crossed)?;
    Ok(out)
}
