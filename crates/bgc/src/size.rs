//! The size of a fault: once the residuals alarm, each parameter of each candidate
//! component fitted alone over the samples since the first alarm, each component with the
//! parameter whose change alone brings every residual closest to its noise, ranked by that;
//! and, on request, the best one's parameter followed window after window over the rest of
//! the record.

use std::fmt::Write as _;
use std::path::Path;

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;
use bondgraph_interpreter::{
    identify, Determined, Estimator, Fit, Identification, Integration, Origin, Record, Settings,
    Span,
};

use crate::identify::significant;
use crate::io;
use crate::record::Data;
use crate::report::{self, Failure};

/// The Savitzky–Golay window the sizes are fitted with (as the model is by `--calibrate`).
const WINDOW: usize = 51;

/// One candidate's fit over a span.
pub(crate) struct Sized {
    /// The component.
    pub(crate) component: String,
    /// The parameter fitted, by its place in the model.
    pub(crate) parameter: usize,
    /// The fit.
    pub(crate) found: Identification,
}

/// What the sizes are fitted on: the model, its (fitted) values and the record.
pub(crate) struct Sizing<'a> {
    pub(crate) c: &'a Compiled,
    pub(crate) program: &'a Program,
    pub(crate) params: &'a [f64],
    pub(crate) data: &'a Data,
}

impl Sizing<'_> {
    /// Each parameter of `component` fitted alone over `[from, to]` seconds, from `start`,
    /// with the residuals integrated from the span's start and from the record's (see
    /// [`Origin`]): the one parameter and origin that fit best. One parameter at a time,
    /// because that is the question (which parameter moved, by how much) and because two
    /// parameters of one law fitted together over a few seconds can trade off without
    /// bound (a dead zone's width and its sigmoid's slope, once the twist is past it).
    fn fit(&self, component: &str, start: &[f64], from: f64, to: f64) -> Option<Sized> {
        let comp = self.c.components.values().find(|k| k.name == component)?;
        (comp.parameters.iter())
            .filter_map(|p| self.fit_parameter(component, p.index(), start, from, to))
            .min_by(|a, b| a.found.cost.1.total_cmp(&b.found.cost.1))
    }

    /// `parameter` of `component` fitted alone over `[from, to]` seconds from `start`, from
    /// whichever origin fits better.
    fn fit_parameter(
        &self,
        component: &str,
        parameter: usize,
        start: &[f64],
        from: f64,
        to: f64,
    ) -> Option<Sized> {
        [Origin::Span, Origin::Record]
            .into_iter()
            .filter_map(|origin| {
                self.fit_from(component, parameter, start, Span { from, to, origin })
            })
            .min_by(|a, b| a.found.cost.1.total_cmp(&b.found.cost.1))
    }

    fn fit_from(
        &self,
        component: &str,
        parameter: usize,
        start: &[f64],
        span: Span,
    ) -> Option<Sized> {
        let to = span.to;
        let settings = Settings {
            fit: Fit {
                step: self.data.step,
                estimator: Estimator::SavitzkyGolay {
                    window: WINDOW,
                    degree: self.program.top_order().max(3),
                },
                // Integrated from the span's start: what a fault adds to a relation while it
                // lasts accumulates over it, the noise only as its square root.
                integration: vec![Integration::Start; self.c.arrs.len()],
            },
            free: vec![parameter],
            bounded: false,
            span: Some(span),
        };
        let end = (self.data.time.iter())
            .position(|&t| t > to)
            .map_or(self.data.time.len(), |k| {
                (k + WINDOW).min(self.data.time.len())
            });
        let record = Record {
            time: &self.data.time[..end],
            raw: self.data.columns.iter().map(|c| &c[..end]).collect(),
        };
        let found = identify(self.c, self.program, start, &[record], &settings).ok()?;
        Some(Sized {
            component: component.to_string(),
            parameter,
            found,
        })
    }

    /// Each candidate of `ranked` (component names, best first, as the episode ranks them)
    /// that has parameters, fitted alone over `span` seconds from `first`, best fit first.
    pub(crate) fn candidates(&self, ranked: &[String], first: f64, span: f64) -> Vec<Sized> {
        let mut sized: Vec<Sized> = (ranked.iter())
            .filter_map(|name| self.fit(name, self.params, first, first + span))
            .collect();
        sized.sort_by(|a, b| a.found.cost.1.total_cmp(&b.found.cost.1));
        sized
    }

    /// The parameter `best` sized, fitted over successive windows of `span` seconds from
    /// `first` to the record's end, each from the fit of the one before: the same parameter
    /// throughout, so that its trend is one series.
    pub(crate) fn follow(&self, best: &Sized, first: f64, span: f64) -> Vec<(f64, f64, Sized)> {
        let end = self.data.time.last().copied().unwrap_or(first);
        let mut start = self.params.to_vec();
        let mut out = Vec::new();
        let mut from = first;
        while from + span <= end + 1e-9 {
            let fitted =
                self.fit_parameter(&best.component, best.parameter, &start, from, from + span);
            let Some(sized) = fitted else {
                break;
            };
            start.clone_from(&sized.found.values);
            out.push((from, from + span, sized));
            from += span;
        }
        out
    }
}

/// The note of the candidates' sizes.
pub(crate) fn note(c: &Compiled, sized: &[Sized], model: &[f64], first: f64, span: f64) {
    if sized.is_empty() {
        return;
    }
    let mut text = format!(
        "the fault's size: each candidate with parameters fitted alone over {span} s from {first} \
         s (the first alarm's samples on), best fit first (residuals over their noise, mean \
         square: 1 is the noise):"
    );
    for (k, s) in sized.iter().enumerate() {
        let _ = write!(
            text,
            "\n   {:>2}  {}: {}; {:.3} (was {:.3})",
            k + 1,
            s.component,
            estimates(c, &s.found, model).join(", "),
            s.found.cost.1,
            s.found.cost.0
        );
    }
    report::note(text);
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
