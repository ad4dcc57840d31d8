//! What goes wrong when equations are oriented, as diagnostics in the user's names: the
//! elements and bonds of the model, never the solver's unknowns.

use std::collections::BTreeSet;

use super::equations::Relation;
use super::solve::Use;
use super::{Causal, Mode};
use crate::diagnostic::{Code, Diagnostic, Severity};
use crate::graph::BondGraph;
use crate::graph::NodeId;

/// Most secondary places shown with one diagnostic; the message still names them all.
const MAX_NOTES: usize = 8;

/// A diagnostic at the first of `nodes`, with the others as notes.
pub(crate) fn at_nodes(
    model: &BondGraph,
    severity: Severity,
    code: Code,
    nodes: &[NodeId],
    message: String,
) -> Diagnostic {
    let mut unique: Vec<NodeId> = Vec::new();
    for &n in nodes {
        if !unique.contains(&n) {
            unique.push(n);
        }
    }
    let span = unique
        .first()
        .map(|&n| model.node(n).span)
        .unwrap_or_default();
    let mut d = match severity {
        Severity::Error => Diagnostic::error(code, span, message),
        Severity::Warning => Diagnostic::warning(code, span, message),
    };
    if let Some(&first) = unique.first() {
        d = d.with_label(format!("`{}` is here", model.node(first).name));
    }
    for &n in unique.iter().skip(1).take(MAX_NOTES) {
        d = d.with_note(
            model.node(n).span,
            format!("`{}` is here", model.node(n).name),
        );
    }
    d
}

/// Storage elements that cannot take the causality the mode needs, each once.
pub(crate) fn refusals(model: &BondGraph, causal: &Causal) -> Vec<Diagnostic> {
    let unsolved = unsolved_roots(model, causal);
    causal
        .system
        .refusals
        .iter()
        .chain(&unsolved)
        .map(|r| {
            let name = &model.node(r.element).name;
            match causal.mode {
                Mode::Integral => at_nodes(
                    model,
                    Severity::Error,
                    Code::NotInvertible,
                    &[r.element],
                    format!("`{name}`: {}", r.reason),
                )
                .with_help("a law that follows its variable in either direction serves: `e = ...q` or `q = ...e` for a C, `f = ...p` or `p = ...f` for an I"),
                // The element keeps integral causality and the ARRs are derived all the same:
                // what they assume is worth saying, not refusing.
                Mode::Diagnosis => at_nodes(
                    model,
                    Severity::Warning,
                    Code::MixedCausality,
                    &[r.element],
                    format!(
                        "`{name}`: {}; it keeps integral causality in diagnosis, so the ARRs read the integrals (`int(..)`) of the signals that set it, taken from the start of the record",
                        r.reason
                    ),
                )
                .with_help("they hold on a record that starts where those integrals are zero (the plant at rest); writing the law the other way (`q = ...e` for a C, `p = ...f` for an I) would spare the integrals"),
            }
        })
        .collect()
}

/// In diagnosis, the storage elements whose law could have been solved for a root (it has no
/// closed-form inverse) and was not: a law that reaches its variable through a function with
/// flat stretches or several roots, or over an unknown that only elimination removes.
fn unsolved_roots(model: &BondGraph, causal: &Causal) -> Vec<super::equations::Refusal> {
    if causal.mode != Mode::Diagnosis {
        return Vec::new();
    }
    let roots = |e| {
        (causal.system.pool.leaves(e).iter()).any(|l| matches!(l, crate::symbolic::Leaf::Root(..)))
    };
    (causal.system.equations.iter().zip(&causal.solved.uses))
        .filter_map(|(eq, u)| {
            let Relation::Storage {
                derivative: None,
                implicit: Some(_),
                ..
            } = eq.relation
            else {
                return None;
            };
            let rooted = match *u {
                Use::Redundant { residual } => roots(residual),
                Use::Solves { class, .. } => class == super::solve::Class::Implicit,
                Use::Pending => false,
            };
            let (energy, co) = match &model.node(eq.owner).kind {
                crate::graph::NodeKind::Element(k, _) if k.base() == crate::graph::ElementKind::I => ("p", "f"),
                _ => ("q", "e"),
            };
            (!rooted).then(|| super::equations::Refusal {
                element: eq.owner,
                reason: format!(
                    "its law gives `{co}` from `{energy}`, has no closed-form inverse, and cannot be solved for `{energy}` numerically here (it reaches it through `abs`, `sign`, `min`, `max`, a periodic function or an integral, or what sets `{co}` is known only to the elimination)"
                ),
            })
        })
        .collect()
}

/// Equations over-determined in integral causality: two causes impose one variable.
pub(crate) fn conflicts(model: &BondGraph, causal: &Causal) -> Vec<Diagnostic> {
    causal
        .redundant()
        .into_iter()
        .map(|(eq, _)| {
            let owner = causal.system.equations[eq].owner;
            let imposed: Vec<String> = causal.system.equations[eq]
                .vars
                .iter()
                .map(|v| causal.system.vars[v.index()].describe(model))
                .collect();
            at_nodes(
                model,
                Severity::Error,
                Code::Conflict,
                &[owner],
                format!(
                    "causal conflict at `{}`: everything it relates ({}) is already imposed by other elements",
                    model.node(owner).name,
                    imposed.join(", ")
                ),
            )
            .with_help(
                "two sources, or a source and a storage element, impose the same variable; \
                 remove one, or put a resistor or a storage element between them",
            )
        })
        .collect()
}

/// The unknowns that could not be computed, with the equations still waiting for them: a
/// nonlinear algebraic loop when one of those is a nonlinear law, else an under-determined
/// part (or one no detector observes, in diagnosis).
pub(crate) fn unsolved(model: &BondGraph, causal: &Causal) -> Option<Diagnostic> {
    let unknowns = causal.unsolved();
    if unknowns.is_empty() {
        return None;
    }
    let names: Vec<String> = unknowns
        .iter()
        .map(|v| causal.system.vars[v.index()].describe(model))
        .collect();
    let open: BTreeSet<_> = unknowns.iter().copied().collect();
    let mut waiting: Vec<NodeId> = Vec::new();
    let mut nonlinear = false;
    for (i, eq) in causal.system.equations.iter().enumerate() {
        if causal.solved.uses[i] == Use::Pending && eq.vars.iter().any(|v| open.contains(v)) {
            waiting.push(eq.owner);
            nonlinear |= matches!(eq.relation, Relation::Law { .. });
        }
    }
    let listed: Vec<String> = waiting
        .iter()
        .map(|&n| format!("`{}`", model.node(n).name))
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let (code, what) = match (nonlinear, causal.mode) {
        (true, _) => (
            Code::AlgebraicLoop,
            "a nonlinear algebraic loop: these laws set each other and bgc cannot solve them in closed form",
        ),
        (false, Mode::Integral) => (
            Code::Underdetermined,
            "an under-determined part: nothing the model knows (sources, states) sets these variables",
        ),
        (false, Mode::Diagnosis) => (
            Code::Underdetermined,
            "a part no detector observes: these variables cannot be computed from known signals",
        ),
    };
    let mode = match causal.mode {
        Mode::Integral => "state equations",
        Mode::Diagnosis => "ARRs",
    };
    // In diagnosis, what cannot be computed only yields fewer ARRs: those written are right.
    let severity = match causal.mode {
        Mode::Integral => Severity::Error,
        Mode::Diagnosis => Severity::Warning,
    };
    let mut nodes = waiting.clone();
    if nodes.is_empty() {
        nodes = unknowns
            .iter()
            .flat_map(|v| causal.system.vars[v.index()].nodes(model))
            .collect();
    }
    Some(
        at_nodes(
            model,
            severity,
            code,
            &nodes,
            format!(
                "{what} ({mode}): {}; the equations of {} wait for them",
                names.join(", "),
                if listed.is_empty() {
                    "no element".to_string()
                } else {
                    listed.join(", ")
                }
            ),
        )
        .with_help(match code {
            Code::AlgebraicLoop => {
                "give one of the laws of the loop in the other direction, or add a storage element that breaks the loop"
            }
            _ => "check that every part of the model is driven by a source (or, for diagnosis, reached by a detector)",
        }),
    )
}
