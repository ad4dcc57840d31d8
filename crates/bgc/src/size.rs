//! The CLI's side of a fault's size: the note, the followed series' file and the residual
//! CSV's size columns (the fits are `bondgraph_interpreter::Sizing`'s).

use std::fmt::Write as _;
use std::path::Path;

use bondgraph_core::Compiled;
use bondgraph_interpreter::{Determined, Identification, Sized};

use crate::identify::significant;
use crate::io;
use crate::report::{self, Failure};

/// The note of the candidates' sizes; `combined`, the parameters calibration found
/// determined only together (by place), whose sizes are ratios only.
pub(crate) fn note(
    c: &Compiled,
    sized: &[Sized],
    (model, combined): (&[f64], &[Vec<usize>]),
    first: f64,
    span: f64,
) {
    if sized.is_empty() {
        report::note(format!(
            "the fault's size: no candidate could be fitted over {} s from {} s (the \
             record ends before the span holds the samples a size needs, or no candidate \
             has a parameter the residuals read)",
            significant(span),
            significant(first)
        ));
        return;
    }
    let mut text = format!(
        "the fault's size: each candidate with parameters fitted alone over {} s from {} \
         s (the first alarm's samples on; residuals taken from the span's start begin half the \
         sizes' estimator window later, so that none reads a sample from before them), best \
         fit first (residuals over their noise, mean \
         square: 1 is the noise):",
        significant(span),
        significant(first)
    );
    for (k, s) in sized.iter().enumerate() {
        let _ = write!(
            text,
            "\n   {:>2}  {}{}: {}; {:.3} (was {:.3})",
            k + 1,
            s.component,
            carried(c, s.parameter),
            estimates(c, &s.found, model).join(", "),
            s.found.cost.1,
            s.found.cost.0
        );
        if let Some(others) = ratio_only(c, s.parameter, combined) {
            let _ = write!(
                text,
                "\n        only the ratio is determined: calibration's record holds {} only \
                 together with {others}, so its value rests on theirs",
                name(c, s.parameter)
            );
        }
    }
    report::note(text);
}

/// The other parameters of the combination `parameter` is determined only in, where it is.
fn ratio_only(c: &Compiled, parameter: usize, combined: &[Vec<usize>]) -> Option<String> {
    let with = combined.iter().find(|places| places.contains(&parameter))?;
    let others: Vec<&str> = (with.iter())
        .filter(|&&k| k != parameter)
        .map(|&k| name(c, k))
        .collect();
    (!others.is_empty()).then(|| others.join(", "))
}

/// A parameter's name, by its place.
fn name(c: &Compiled, parameter: usize) -> &str {
    c.parameters
        .values()
        .nth(parameter)
        .map_or("", |p| p.name.as_str())
}

/// ` (sensor gain)` where the parameter sized is a fault a detector or a source carries.
fn carried(c: &Compiled, parameter: usize) -> String {
    (c.parameters.values().nth(parameter))
        .and_then(|p| p.carried.as_ref())
        .map_or_else(String::new, |f| {
            format!(" ({})", f.fault.describe(f.sensor))
        })
}

/// `j0 = 0.61 rad ± 0.02, 3.050× the model's 0.2 (+0.41 rad)` for each parameter fitted.
fn estimates(c: &Compiled, found: &Identification, model: &[f64]) -> Vec<String> {
    (found.estimates.iter())
        .filter(|e| {
            matches!(
                e.determined,
                Determined::Yes | Determined::Weakly | Determined::No
            )
        })
        .map(|e| {
            let unit = c
                .parameters
                .values()
                .nth(e.parameter)
                .and_then(|p| p.unit.clone());
            let unit = unit.map_or_else(String::new, |u| format!(" {u}"));
            let reference = model[e.parameter];
            // A change by a factor reads best for a coefficient, one by an amount for an
            // offset: both are given.
            let change = format!(
                "{}{}{unit}",
                if e.value >= reference { "+" } else { "" },
                significant(e.value - reference)
            );
            let ratio = if reference == 0.0 {
                format!(" ({change} from the model's 0)")
            } else {
                format!(
                    ", {:.3}× the model's {} ({change})",
                    e.value / reference,
                    significant(reference)
                )
            };
            let interval = if e.half_width.is_finite() {
                format!(" ± {}", significant(e.half_width))
            } else {
                " (not determined alone)".to_string()
            };
            format!(
                "{} = {}{unit}{interval}{ratio}",
                e.name,
                significant(e.value)
            )
        })
        .collect()
}

/// Writes the followed sizes as CSV: `from,to,component,parameter,value,half_width,ratio`.
pub(crate) fn write_followed(
    path: &Path,
    followed: &[(f64, f64, Sized)],
    model: &[f64],
) -> Result<(), Failure> {
    let mut out = String::from("from,to,component,parameter,value,half_width,ratio\n");
    for (from, to, sized) in followed {
        for e in &sized.found.estimates {
            if !matches!(
                e.determined,
                Determined::Yes | Determined::Weakly | Determined::No
            ) {
                continue;
            }
            let reference = model[e.parameter];
            let ratio = if reference == 0.0 {
                f64::NAN
            } else {
                e.value / reference
            };
            let _ = write!(out, "{from},{to},{},{},", sized.component, e.name);
            io::push_number(&mut out, e.value);
            out.push(',');
            if e.half_width.is_finite() {
                io::push_number(&mut out, e.half_width);
            }
            out.push(',');
            if ratio.is_finite() {
                io::push_number(&mut out, ratio);
            }
            out.push('\n');
        }
    }
    io::write(Some(path), &out)
}

/// One stretch of the residual CSV's size columns: from `known` seconds on (the end of the
/// span it was fitted over: no row shows an estimate before its samples were seen), the
/// parameter sized, its value and its interval's half-width.
pub(crate) struct Known {
    pub(crate) known: f64,
    pub(crate) parameter: String,
    pub(crate) value: f64,
    pub(crate) half_width: f64,
}

/// The size columns' stretches: the best candidate over its first span, then (with
/// `--sizes`) each span it was followed over.
pub(crate) fn known(
    best: &Sized,
    first: f64,
    span: f64,
    followed: &[(f64, f64, Sized)],
) -> Vec<Known> {
    let of = |known: f64, sized: &Sized| {
        (sized.found.estimates.iter())
            .find(|e| e.parameter == sized.parameter)
            .map(|e| Known {
                known,
                parameter: e.name.clone(),
                value: e.value,
                half_width: e.half_width,
            })
    };
    let mut out: Vec<Known> = of(first + span, best).into_iter().collect();
    // The first followed span is the best candidate's own.
    out.extend(followed.iter().skip(1).filter_map(|(_, to, s)| of(*to, s)));
    out
}

/// `out`, the residual CSV whose rows end in three empty size cells, with those of the rows
/// from each stretch's `known` on filled.
pub(crate) fn fill(out: String, stretches: &[Known]) -> String {
    let Some(first) = stretches.first() else {
        return out;
    };
    let mut filled = String::with_capacity(out.len() + out.len() / 4);
    let mut lines = out.split_inclusive('\n');
    if let Some(header) = lines.next() {
        filled.push_str(header);
    }
    let mut next = 0;
    for line in lines {
        let t: f64 = (line.split(',').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or(f64::NEG_INFINITY);
        while next < stretches.len() && stretches[next].known <= t {
            next += 1;
        }
        let body = line.trim_end_matches('\n').strip_suffix(",,,");
        match (body, next.checked_sub(1).map(|k| &stretches[k])) {
            (Some(body), Some(k)) if t >= first.known => {
                filled.push_str(body);
                filled.push(',');
                filled.push_str(&k.parameter);
                filled.push(',');
                io::push_number(&mut filled, k.value);
                filled.push(',');
                if k.half_width.is_finite() {
                    io::push_number(&mut filled, k.half_width);
                }
                filled.push('\n');
            }
            _ => filled.push_str(line),
        }
    }
    filled
}
