//! `read_columns`: a record written by a logger (a MAT-file, TDMS, MDF 4) read from its path
//! into the columns the residuals need, by the readers `bgc residuals` uses.

use numpy::PyArray1;
use pyo3::prelude::*;

use crate::errors;

/// The columns `names` of the record at `path`, as float64 arrays in that order, when it is
/// a MAT-file, TDMS or MDF 4 (by its first bytes); `None` for any other file (CSV and Parquet
/// are read by pandas). A column the file lacks, or cannot give as numbers, raises
/// `DataError` naming it.
#[pyfunction]
pub(crate) fn read_columns<'py>(
    py: Python<'py>,
    path: &str,
    names: Vec<String>,
) -> PyResult<Option<Vec<Bound<'py, PyArray1<f64>>>>> {
    let bytes = std::fs::read(path)
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{path}: {e}")))?;
    let Some(format) = bondgraph_records::Format::of(&bytes) else {
        return Ok(None);
    };
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let columns = py
        .detach(|| bondgraph_records::columns(format, &bytes, &names))
        .map_err(|e| errors::data(format!("{path} ({}): {e}", format.name())))?;
    Ok(Some(
        columns
            .into_iter()
            .map(|c| PyArray1::from_vec(py, c))
            .collect(),
    ))
}
