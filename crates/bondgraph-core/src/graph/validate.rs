//! Structural checks on a lowered graph: port counts, power directions, detector placement.

use std::collections::HashSet;

use petgraph::Direction::{Incoming, Outgoing};

use super::model::{BondGraph, BondId, BondKind, DetectorKind, ElementKind, NodeId, NodeKind};
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Span};

/// Checks every node's bonds against its kind, but for the `uncertain` ones (a statement
/// declaring or bonding them had an error, already reported); `model_span` locates
/// whole-model errors.
pub(crate) fn structure(
    model: &BondGraph,
    model_span: Option<Span>,
    uncertain: &HashSet<NodeId>,
    diagnostics: &mut Diagnostics,
) {
    if model.graph.edge_count() == 0 && !diagnostics.has_errors() {
        diagnostics.push(
            Diagnostic::error(
                Code::Empty,
                model_span.unwrap_or_default(),
                "the model has no bonds",
            )
            .with_label("expected elements joined by bonds, e.g. `U -> 1:j -> R1`"),
        );
        return;
    }
    if model.graph.edge_count() == 0 {
        return;
    }
    for id in model.nodes().filter(|id| !uncertain.contains(id)) {
        let bonds = Ports::of(model, id);
        match model.node(id).kind {
            NodeKind::Junction(_) => junction(model, id, &bonds, diagnostics),
            NodeKind::Element(kind, _) => element(model, id, kind, &bonds, diagnostics),
            NodeKind::Detector(kind) => detector(model, id, kind, &bonds, diagnostics),
        }
    }
}

/// A node's bonds, split by direction.
struct Ports {
    incoming: Vec<BondId>,
    outgoing: Vec<BondId>,
}

impl Ports {
    fn of(model: &BondGraph, id: NodeId) -> Ports {
        Ports {
            incoming: model.bonds_at(id, Incoming),
            outgoing: model.bonds_at(id, Outgoing),
        }
    }

    fn all(&self) -> impl Iterator<Item = BondId> + '_ {
        self.incoming.iter().chain(&self.outgoing).copied()
    }

    fn count(&self) -> usize {
        self.incoming.len() + self.outgoing.len()
    }
}

fn with_bonds(
    mut d: Diagnostic,
    model: &BondGraph,
    bonds: impl Iterator<Item = BondId>,
) -> Diagnostic {
    for b in bonds {
        let bond = model.bond(b);
        d = d.with_note(bond.span, format!("bond {}", bond.number));
    }
    d
}

fn junction(model: &BondGraph, id: NodeId, ports: &Ports, diagnostics: &mut Diagnostics) {
    let power: Vec<BondId> = ports
        .all()
        .filter(|&b| model.bond(b).kind == BondKind::Power)
        .collect();
    if power.len() < 2 {
        let node = model.node(id);
        let kind = node.junction_kind().map_or("", |k| k.symbol());
        diagnostics.push(with_bonds(
            Diagnostic::error(
                Code::PortCount,
                node.span,
                format!(
                    "{kind}-junction `{}` has {} power bond{}",
                    node.name,
                    power.len(),
                    if power.len() == 1 { "" } else { "s" }
                ),
            )
            .with_label("expected at least 2 power bonds")
            .with_help(
                "a junction joins two or more bonds; bond it to something else or remove it",
            ),
            model,
            power.into_iter(),
        ));
    }
}

fn element(
    model: &BondGraph,
    id: NodeId,
    kind: ElementKind,
    ports: &Ports,
    diagnostics: &mut Diagnostics,
) {
    let node = model.node(id);
    let expected = if kind.is_two_port() { 2 } else { 1 };
    if ports.count() != expected {
        let d = Diagnostic::error(
            Code::PortCount,
            node.span,
            format!(
                "{} `{}` has {} bond{}",
                kind.name(),
                node.name,
                ports.count(),
                if ports.count() == 1 { "" } else { "s" }
            ),
        )
        .with_label(format!(
            "expected exactly {expected} bond{}",
            if expected == 1 { "" } else { "s" }
        ));
        let d = if ports.count() == 0 {
            d.with_help(format!(
                "bond it to a junction, e.g. `{} -> 1:j`",
                node.name
            ))
        } else {
            d
        };
        diagnostics.push(with_bonds(d, model, ports.all()));
        return;
    }
    let (want_in, want_out, rule) = if kind.is_source() {
        (0, 1, "a source's bond points out of it")
    } else if kind.is_two_port() {
        (
            1,
            1,
            "power passes through a two-port: one bond in, one bond out",
        )
    } else {
        (1, 0, "the bond of R, C and I points into the element")
    };
    if ports.incoming.len() != want_in || ports.outgoing.len() != want_out {
        diagnostics.push(with_bonds(
            Diagnostic::error(
                Code::Direction,
                node.span,
                format!(
                    "{} `{}` has {} bond{} in and {} out",
                    kind.name(),
                    node.name,
                    ports.incoming.len(),
                    if ports.incoming.len() == 1 { "" } else { "s" },
                    ports.outgoing.len()
                ),
            )
            .with_label(format!("expected {want_in} in and {want_out} out"))
            .with_help(format!("{rule}; reverse the arrow")),
            model,
            ports.all(),
        ));
    }
}

fn detector(
    model: &BondGraph,
    id: NodeId,
    kind: DetectorKind,
    ports: &Ports,
    diagnostics: &mut Diagnostics,
) {
    let node = model.node(id);
    if ports.count() != 1 {
        let d = Diagnostic::error(
            Code::PortCount,
            node.span,
            format!(
                "detector `{}` is attached {} times",
                node.name,
                ports.count()
            ),
        )
        .with_label("expected exactly one attachment");
        let d = if ports.count() == 0 {
            d.with_help(format!(
                "attach it with `{} {} on JUNCTION` or a bond `JUNCTION -> {}`",
                kind.name(),
                node.name,
                node.name
            ))
        } else {
            d
        };
        diagnostics.push(with_bonds(d, model, ports.all()));
        return;
    }
    let Some(&bond) = ports.incoming.first() else {
        return;
    };
    let (junction, _) = model.ends(bond);
    let junction_node = model.node(junction);
    if junction_node.junction_kind() != Some(kind.junction()) {
        let (reads, common) = match kind {
            DetectorKind::De => ("an effort", "a 0-junction"),
            DetectorKind::Df => ("a flow", "a 1-junction"),
            DetectorKind::Dq => ("the integral of a flow", "a 1-junction"),
            DetectorKind::Dp => ("the integral of an effort", "a 0-junction"),
        };
        let other = match kind {
            DetectorKind::De => "Df to measure the flow",
            DetectorKind::Df => "De to measure the effort",
            DetectorKind::Dq => "Dp to measure the integral of the effort",
            DetectorKind::Dp => "Dq to measure the integral of the flow",
        };
        diagnostics.push(
            Diagnostic::error(
                Code::Detector,
                model.bond(bond).span,
                format!(
                    "{} `{}` reads {reads}, which is common to all bonds only on {common}",
                    kind.name(),
                    node.name
                ),
            )
            .with_label(format!("`{}` is not {common}", junction_node.name))
            .with_note(node.span, "the detector is declared here")
            .with_help(format!("attach it to {common}, or use {other}")),
        );
    }
}
