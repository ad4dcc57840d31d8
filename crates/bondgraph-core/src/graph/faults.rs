//! A detector's or a source's `with` clause: the sensor and actuator faults it carries, each
//! bound to a parameter of the model.

use std::collections::HashSet;

use super::model::{Carried, Faults, Signal};
use super::scope::{Lookup, Scope, SignalSlot};
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use crate::syntax::ast::Ident;

/// What carries the faults: which words its clause accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Carrier {
    /// A detector: `bias`, `gain`, `drift`.
    Sensor,
    /// A source: `gain`, `offset`.
    Actuator,
    /// Any other element: no fault clause.
    Other,
}

impl Carrier {
    fn accepts(self) -> &'static [Carried] {
        match self {
            Carrier::Sensor => &[Carried::Bias, Carried::Gain, Carried::Drift],
            Carrier::Actuator => &[Carried::Gain, Carried::Offset],
            Carrier::Other => &[],
        }
    }

    fn expected(self) -> String {
        let words: Vec<String> = (self.accepts().iter())
            .map(|f| format!("`{}`", f.name()))
            .collect();
        words.join(", ")
    }
}

/// The faults a `with` clause states, each bound to its parameter (marked used); every problem
/// reported at its word.
pub(super) fn resolve(
    carrier: Carrier,
    owner: &Ident,
    clause: &[(Ident, Ident)],
    scope: &Scope,
    used: &mut HashSet<Signal>,
    diagnostics: &mut Diagnostics,
) -> Faults {
    let mut out = Faults::default();
    let mut seen: Vec<(Carried, Span)> = Vec::new();
    for (word, param) in clause {
        let Some(fault) = fault(carrier, owner, word, diagnostics) else {
            continue;
        };
        if let Some((_, first)) = seen.iter().find(|(f, _)| *f == fault) {
            diagnostics.push(
                Diagnostic::error(
                    Code::Duplicate,
                    word.span,
                    format!("`{}` carries a {} twice", owner.name, fault.name()),
                )
                .with_label("expected each fault once")
                .with_note(*first, "first stated here"),
            );
            continue;
        }
        seen.push((fault, word.span));
        match scope.signal(&param.name) {
            Lookup::Found((SignalSlot::Param(id), _)) => {
                used.insert(Signal::Param(id));
                out.0.push((fault, id));
            }
            Lookup::Broken => {}
            Lookup::Found(_) => diagnostics.push(not_a_parameter(param, fault)),
            Lookup::Missing => diagnostics.push(
                not_a_parameter(param, fault)
                    .with_help(format!("declare it, e.g. {}", declaration(param, fault))),
            ),
        }
    }
    out
}

/// The fault a word names, if `carrier` may carry it (reported otherwise).
fn fault(
    carrier: Carrier,
    owner: &Ident,
    word: &Ident,
    diagnostics: &mut Diagnostics,
) -> Option<Carried> {
    if carrier == Carrier::Other {
        diagnostics.push(
            Diagnostic::error(
                Code::BadLaw,
                word.span,
                format!("`{}` cannot carry a sensor or actuator fault", owner.name),
            )
            .with_label("expected no `with` here")
            .with_help(
                "detectors carry `bias`, `gain` and `drift`, sources `gain` and `offset`; a \
                 component's own faults are its parameters",
            ),
        );
        return None;
    }
    match Carried::from_name(&word.name) {
        Some(f) if carrier.accepts().contains(&f) => Some(f),
        _ => {
            let what = match carrier {
                Carrier::Sensor => "a detector",
                _ => "a source",
            };
            diagnostics.push(
                Diagnostic::error(
                    Code::BadLaw,
                    word.span,
                    format!("{what} cannot carry a `{}`", word.name),
                )
                .with_label(format!("expected {}", carrier.expected())),
            );
            None
        }
    }
}

fn not_a_parameter(param: &Ident, fault: Carried) -> Diagnostic {
    Diagnostic::error(
        Code::BadReference,
        param.span,
        format!("the {} `{}` is not a parameter", fault.name(), param.name),
    )
    .with_label("expected a parameter, whose value is the healthy one")
}

fn declaration(param: &Ident, fault: Carried) -> String {
    let healthy = if fault == Carried::Gain { 1 } else { 0 };
    format!("`param {} = {healthy}`", param.name)
}
