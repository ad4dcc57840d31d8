//! What every command reads and writes: models compiled with their diagnostics shown, files
//! written whole or not at all, numbers and times as a person reads them.

use std::path::Path;

use bondgraph_core::{
    Compiled, Derive, Limits, Options, ParameterValues, Realise, ResidualSet, Stop, Unsimplified,
};

use crate::report::{self, Failure};

/// Exit 1 when some output was refused: its errors were reported.
pub(crate) fn succeeded(c: &Compiled) -> Result<(), Failure> {
    if c.has_errors() {
        Err(Failure::Invalid)
    } else {
        Ok(())
    }
}

/// Names what the simplifier skipped and why; what the budget left out, in one line.
fn warn_unsimplified(skipped: &[Unsimplified]) {
    let over_budget: Vec<&str> = skipped
        .iter()
        .filter(|s| s.stop == Stop::Budget)
        .map(|s| s.what.as_str())
        .collect();
    for s in skipped.iter().filter(|s| s.stop != Stop::Budget) {
        report::warn(format!(
            "{} is shown in canonical form: it is larger than --egg-nodes",
            s.what
        ));
    }
    if let [first, ..] = over_budget.as_slice() {
        report::warn(format!(
            "{} expressions, from {first} on, are shown in canonical form: \
             --egg-budget was spent on the ones before",
            over_budget.len()
        ));
    }
}

/// Reads a model (a file, or standard input for `-`) and compiles it, reporting every
/// diagnostic on standard error.
pub(crate) fn compile(
    path: &Path,
    derive: Derive,
    simplify: Option<Limits>,
) -> Result<Compiled, Failure> {
    compile_with(
        path,
        None,
        derive,
        simplify,
        (ResidualSet::PerSensor, Realise::default()),
    )
}

/// [`compile`] with the parameter values of a parameter file (`--params`) in place of the
/// model's, the residual set asked for and how to realise them.
pub(crate) fn compile_with(
    path: &Path,
    values: Option<&Path>,
    derive: Derive,
    simplify: Option<Limits>,
    (residuals, realise): (ResidualSet, Realise),
) -> Result<Compiled, Failure> {
    let (name, bytes) = read(path)?;
    let bytes = match values {
        Some(values) => with_values(bytes, values)?,
        None => bytes,
    };
    let options = Options {
        derive,
        simplify,
        residuals,
        realise,
    };
    let out = report::compile(&name, bytes, &options).ok_or(Failure::Invalid)?;
    warn_unsimplified(&out.unsimplified);
    Ok(out.compiled)
}

/// The parameter file at `path`, read and checked.
pub(crate) fn read_values(path: &Path) -> Result<ParameterValues, Failure> {
    let (name, bytes) = read(path)?;
    let text = String::from_utf8(bytes)
        .map_err(|_| report::usage(format!("{name}: a parameter file is UTF-8 text")))?;
    ParameterValues::parse(&text).map_err(|e| report::usage(format!("{name}:{e}")))
}

/// A model's text with the values of the parameter file at `values`: its lines, columns and
/// everything but the values stay as they were, so that every diagnostic points where it
/// would in the model.
fn with_values(model: Vec<u8>, values: &Path) -> Result<Vec<u8>, Failure> {
    let file = read_values(values)?;
    // A model that is not UTF-8 is the compiler's to report.
    let Ok(text) = String::from_utf8(model.clone()) else {
        return Ok(model);
    };
    let text = file
        .apply(&text)
        .map_err(|e| report::usage(format!("{}:{e}", values.display())))?;
    Ok(text.into_bytes())
}

/// A model or record's name and bytes, from a file or standard input (`-`).
pub(crate) fn read(path: &Path) -> Result<(String, Vec<u8>), Failure> {
    use std::io::Read as _;
    if path == Path::new("-") {
        let mut bytes = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut bytes)
            .map_err(|e| report::usage(format!("cannot read standard input: {e}")))?;
        return Ok(("<stdin>".to_string(), bytes));
    }
    let bytes = std::fs::read(path)
        .map_err(|e| report::usage(format!("cannot read `{}`: {e}", path.display())))?;
    Ok((path.display().to_string(), bytes))
}

/// Appends `v` in the shortest form that reads back to the same `f64` (`1e-7`, `0.25`,
/// `3.0`): the CSV writers print millions of numbers, and this is a few times faster than
/// `Display`.
pub(crate) fn push_number(out: &mut String, v: f64) {
    out.push_str(ryu::Buffer::new().format(v));
}

/// A duration for a message, to 9 significant digits: a step of `0.002`, not of
/// `0.0020000000000000018`, which is what a difference of two sample times holds.
pub(crate) fn seconds(x: f64) -> String {
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    ryu::Buffer::new().format(rounded).to_string()
}

/// Time `t` on a record of step `step`, rounded to a millionth of the step's decade: what
/// sums of steps add in the last bits (`9.908000000000001`, `0.005999999999999999`) is not
/// written. Dividing by a power of ten, exact up to 1e22, gives the double nearest the
/// decimal, which prints as it.
pub(crate) fn tidy_time(t: f64, step: f64) -> f64 {
    if !(t.is_finite() && step.is_finite() && step > 0.0) {
        return t;
    }
    let digits = (6.0 - step.log10().floor()).clamp(0.0, 22.0);
    let scale = 10f64.powi(digits as i32);
    let scaled = (t * scale).round();
    // Past 2^53 the scaled time is no longer exact: leave it as it is.
    if scaled.abs() < 9.0e15 {
        scaled / scale
    } else {
        t
    }
}

/// Writes `text` to `path` (whole or not at all: [`crate::output`]) or standard output.
pub(crate) fn write(path: Option<&Path>, text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let result = match path {
        Some(path) => crate::output::replace(path, text.as_bytes())
            .map_err(|e| (path.display().to_string(), e)),
        None => std::io::stdout()
            .lock()
            .write_all(text.as_bytes())
            .map_err(|e| ("standard output".to_string(), e)),
    };
    result.map_err(|(place, e)| report::usage(format!("cannot write {place}: {e}")))
}
