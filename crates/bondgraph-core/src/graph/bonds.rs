//! Chains and detector attachments turned into numbered bonds.
//!
//! A chain `a, b -> c` bonds every node of a group to every node of the next, power along the
//! arrow. Explicit numbers (`-[7]->`) are kept; the other bonds take the lowest unused numbers
//! in source order, so adding a number to one arrow never renumbers the rest unexpectedly.

use std::collections::HashMap;

use petgraph::graph::DiGraph;

use super::model::{Bond, BondKind, Node, NodeId, NodeKind};
use super::scope::{Lookup, Scope};
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use crate::syntax::ast::{Chain, Ident, NodeRef};

/// A bond before numbering.
struct Draft {
    tail: NodeId,
    head: NodeId,
    kind: BondKind,
    number: Option<u32>,
    span: Span,
}

/// Adds the bonds of every chain, then those of `Df y on J` attachments, to `graph`.
/// Returns the nodes of a statement that had an error: some of their bonds may be missing,
/// so their bond counts prove nothing.
pub(crate) fn build(
    graph: &mut DiGraph<Node, Bond>,
    chains: &[&Chain],
    attachments: &[(NodeId, &Ident)],
    scope: &Scope,
    diagnostics: &mut Diagnostics,
) -> Vec<NodeId> {
    let mut drafts = Vec::new();
    let mut uncertain = Vec::new();
    for chain in chains {
        let before = diagnostics.len();
        let complete = chain_bonds(graph, chain, scope, diagnostics, &mut drafts);
        if !complete || diagnostics.len() > before {
            let named = chain.groups.iter().flatten();
            uncertain.extend(named.filter_map(|n| match scope.node(&n.name.name) {
                Lookup::Found((id, _)) => Some(id),
                _ => None,
            }));
        }
    }
    for &(detector, junction) in attachments {
        let Some(j) = resolve(scope, junction, diagnostics) else {
            uncertain.push(detector);
            continue;
        };
        if is_junction(graph, j) {
            drafts.push(Draft {
                tail: j,
                head: detector,
                kind: BondKind::Signal,
                number: None,
                span: junction.span,
            });
        } else {
            diagnostics.push(not_a_junction(graph, detector, junction.span));
            uncertain.push(detector);
        }
    }
    for (draft, number) in number(&drafts, diagnostics) {
        graph.add_edge(
            draft.tail.0,
            draft.head.0,
            Bond {
                number,
                kind: draft.kind,
                span: draft.span,
            },
        );
    }
    uncertain
}

/// Drafts the bonds of one chain; whether every node it names was found.
fn chain_bonds(
    graph: &DiGraph<Node, Bond>,
    chain: &Chain,
    scope: &Scope,
    diagnostics: &mut Diagnostics,
    drafts: &mut Vec<Draft>,
) -> bool {
    let groups: Vec<Vec<Option<(NodeId, Span)>>> = chain
        .groups
        .iter()
        .map(|group| {
            group
                .iter()
                .map(|n| resolve_ref(graph, scope, n, diagnostics).map(|id| (id, n.span)))
                .collect()
        })
        .collect();
    let complete = groups.iter().flatten().all(Option::is_some);
    for (i, arrow) in chain.arrows.iter().enumerate() {
        let (left, right) = (&groups[i], &groups[i + 1]);
        let number = arrow.number.map(|(n, _)| n);
        if number.is_some() && left.len() * right.len() > 1 {
            diagnostics.push(
                Diagnostic::error(
                    Code::BondNumber,
                    arrow.span,
                    format!(
                        "a numbered arrow must make one bond, this one makes {}",
                        left.len() * right.len()
                    ),
                )
                .with_label("expected one node on each side of a numbered arrow")
                .with_help("write each bond on its own line to number it"),
            );
        }
        for &(a, a_span) in left.iter().flatten() {
            for &(b, b_span) in right.iter().flatten() {
                let (tail, head) = if arrow.forward { (a, b) } else { (b, a) };
                let span = a_span.to(b_span);
                if let Some(kind) = bond_kind(graph, tail, head, span, diagnostics) {
                    drafts.push(Draft {
                        tail,
                        head,
                        kind,
                        number,
                        span: arrow.span,
                    });
                }
            }
        }
    }
    complete
}

/// Whether a bond between these nodes can exist, and of which kind.
fn bond_kind(
    graph: &DiGraph<Node, Bond>,
    tail: NodeId,
    head: NodeId,
    span: Span,
    diagnostics: &mut Diagnostics,
) -> Option<BondKind> {
    let is_detector = |n: NodeId| matches!(graph[n.0].kind, NodeKind::Detector(_));
    if tail == head {
        diagnostics.push(
            Diagnostic::error(
                Code::BadBond,
                span,
                format!("`{}` is bonded to itself", graph[tail.0].name),
            )
            .with_label("expected two different nodes"),
        );
        return None;
    }
    if is_detector(tail) {
        diagnostics.push(
            Diagnostic::error(
                Code::Direction,
                span,
                format!("power cannot come out of detector `{}`", graph[tail.0].name),
            )
            .with_label("expected the arrow to point at the detector")
            .with_help(format!(
                "a detector draws no power; write `{} -> {}`",
                graph[head.0].name, graph[tail.0].name
            )),
        );
        return None;
    }
    if is_detector(head) {
        if !is_junction(graph, tail) {
            diagnostics.push(not_a_junction(graph, head, span));
            return None;
        }
        return Some(BondKind::Signal);
    }
    Some(BondKind::Power)
}

fn is_junction(graph: &DiGraph<Node, Bond>, id: NodeId) -> bool {
    graph[id.0].is_junction()
}

fn not_a_junction(graph: &DiGraph<Node, Bond>, detector: NodeId, span: Span) -> Diagnostic {
    Diagnostic::error(
        Code::Detector,
        span,
        format!(
            "detector `{}` must be attached to a junction",
            graph[detector.0].name
        ),
    )
    .with_label("expected a 0-junction (for De, Dp) or a 1-junction (for Df, Dq)")
}

fn resolve_ref(
    graph: &DiGraph<Node, Bond>,
    scope: &Scope,
    node: &NodeRef,
    diagnostics: &mut Diagnostics,
) -> Option<NodeId> {
    if let Some(kind) = node.junction {
        // Declared (or reported) when the chain was first read. A declaration that lost to
        // another node of the same name was reported as a duplicate: its bonds are not
        // made to that other node.
        return match scope.node(&node.name.name) {
            Lookup::Found((id, _)) if graph[id.0].kind == NodeKind::Junction(kind) => Some(id),
            _ => None,
        };
    }
    resolve(scope, &node.name, diagnostics)
}

fn resolve(scope: &Scope, name: &Ident, diagnostics: &mut Diagnostics) -> Option<NodeId> {
    match scope.node(&name.name) {
        Lookup::Found((id, _)) => Some(id),
        Lookup::Broken => None,
        Lookup::Missing => {
            let d = Diagnostic::error(
                Code::Undefined,
                name.span,
                format!("no element, junction or detector is named `{}`", name.name),
            )
            .with_label(
                "expected a declared element or detector, or a junction `0:NAME` / `1:NAME`",
            );
            diagnostics.push(match scope.similar_node(&name.name) {
                Some(near) => d.with_help(format!("did you mean `{near}`?")),
                None => d.with_help(format!(
                    "declare it (e.g. `R {} = 1`) or write it as a junction, `0:{}` or `1:{}`",
                    name.name, name.name, name.name
                )),
            });
            None
        }
    }
}

/// Numbers for every draft: explicit ones checked for reuse, the rest filled in from 1.
fn number<'d>(drafts: &'d [Draft], diagnostics: &mut Diagnostics) -> Vec<(&'d Draft, u32)> {
    let mut taken: HashMap<u32, Span> = HashMap::new();
    for draft in drafts {
        let Some(n) = draft.number else { continue };
        if n == 0 {
            diagnostics.push(
                Diagnostic::error(Code::BondNumber, draft.span, "bond numbers start at 1")
                    .with_label("expected a number from 1"),
            );
        } else if let Some(&first) = taken.get(&n) {
            if first != draft.span {
                diagnostics.push(
                    Diagnostic::error(
                        Code::BondNumber,
                        draft.span,
                        format!("bond {n} is numbered twice"),
                    )
                    .with_label("expected a number no other bond has")
                    .with_note(first, format!("bond {n} is here")),
                );
            }
        } else {
            taken.insert(n, draft.span);
        }
    }
    let mut next = 1;
    drafts
        .iter()
        .map(|draft| {
            let n = match draft.number {
                Some(n) => n,
                None => {
                    while taken.contains_key(&next) {
                        next += 1;
                    }
                    taken.insert(next, draft.span);
                    next
                }
            };
            (draft, n)
        })
        .collect()
}
