//! Recorded samples read from Parquet (what pandas, pyarrow, Polars and Spark write): the
//! same columns and checks as a CSV record, read through arrow-rs.

use arrow_array::cast::AsArray;
use arrow_array::types::Float64Type;
use arrow_array::{Array, RecordBatch};
use arrow_schema::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// The first bytes of every Parquet file.
pub(crate) const MAGIC: &[u8] = b"PAR1";

/// The columns `names` of the Parquet file `bytes`, in that order, as numbers; the first
/// missing, null or non-numeric cell is an error naming its row (counted from 1) and column.
pub(crate) fn columns(bytes: Vec<u8>, names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    let builder = ParquetRecordBatchReaderBuilder::try_new(bytes::Bytes::from(bytes))
        .map_err(|e| format!("cannot read it as Parquet: {e}"))?;
    let schema = builder.schema().clone();
    let present: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    let mut at = Vec::with_capacity(names.len());
    for &name in names {
        let places: Vec<usize> = (present.iter().enumerate())
            .filter(|(_, p)| **p == name)
            .map(|(k, _)| k)
            .collect();
        match places.as_slice() {
            [k] => at.push(*k),
            [] => {
                let near = bondgraph_core::closest(name, present.iter().copied());
                let hint = near.map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
                return Err(format!(
                    "no column `{name}`{hint}; the file has {}",
                    present.join(", ")
                ));
            }
            _ => {
                return Err(format!(
                    "the file names `{name}` {} times: keep one",
                    places.len()
                ))
            }
        }
    }
    for (&k, name) in at.iter().zip(names) {
        let kind = schema.field(k).data_type();
        if !(kind.is_numeric() || matches!(kind, DataType::Dictionary(_, v) if v.is_numeric())) {
            return Err(format!("column `{name}` holds {kind} values, not numbers"));
        }
    }
    let rows = usize::try_from(builder.metadata().file_metadata().num_rows()).unwrap_or(0);
    let reader = builder
        .build()
        .map_err(|e| format!("cannot read it as Parquet: {e}"))?;
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows); names.len()];
    for batch in reader {
        let batch = batch.map_err(|e| format!("cannot read it as Parquet: {e}"))?;
        append(&batch, &at, names, &mut columns)?;
    }
    Ok(columns)
}

/// Appends the columns `at` of `batch` to `columns`.
fn append(
    batch: &RecordBatch,
    at: &[usize],
    names: &[&str],
    columns: &mut [Vec<f64>],
) -> Result<(), String> {
    for ((&k, name), column) in at.iter().zip(names).zip(columns.iter_mut()) {
        let first = column.len();
        let values = arrow_cast::cast(batch.column(k), &DataType::Float64)
            .map_err(|e| format!("column `{name}`: {e}"))?;
        let values = values.as_primitive::<Float64Type>();
        if let Some(row) = (0..values.len()).find(|&i| values.is_null(i)) {
            return Err(format!(
                "row {}, column `{name}`: an empty cell",
                first + row + 1
            ));
        }
        let slice = values.values();
        if let Some(row) = slice.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "row {}, column `{name}`: `{}` is not a finite number",
                first + row + 1,
                slice[row]
            ));
        }
        column.extend_from_slice(slice);
    }
    Ok(())
}
