//! Graphviz DOT of a bond graph: half-arrows along positive power, bond numbers, `KIND:name`.
//!
//! Signal bonds to detectors are drawn dashed with a full arrow, as activated bonds are in the
//! literature. Given a causality, each power bond also gets its causal stroke, at the end that
//! receives the effort. Output depends only on the model, so it is stable from run to run.

use std::fmt::Write as _;

use bondgraph_core::causality::Causal;
use bondgraph_core::graph::{BondGraph, BondKind, NodeKind};

/// The model as a DOT digraph, with causal strokes when `causal` is given.
pub fn emit(model: &BondGraph, causal: Option<&Causal>) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "digraph {} {{", quote(&model.name));
    let _ = writeln!(out, "  graph [rankdir=LR, fontname=\"Helvetica\"];");
    let _ = writeln!(
        out,
        "  node [shape=plaintext, fontname=\"Helvetica\"];\n  edge [fontname=\"Helvetica\", fontsize=10];"
    );
    for id in model.nodes() {
        let node = model.node(id);
        let label = match &node.kind {
            NodeKind::Junction(kind) => kind.symbol().to_string(),
            NodeKind::Element(kind, _) => format!("{}:{}", kind.name(), node.name),
            NodeKind::Detector(kind) => format!("{}:{}", kind.name(), node.name),
        };
        let tooltip = match &node.kind {
            NodeKind::Junction(_) => node.name.clone(),
            NodeKind::Element(_, law) => model.show(law.expr()),
            NodeKind::Detector(_) => node.description.clone().unwrap_or_default(),
        };
        let _ = writeln!(
            out,
            "  n{} [label={}, tooltip={}];",
            id.0.index(),
            quote(&label),
            quote(&tooltip)
        );
    }
    for id in model.bonds() {
        let bond = model.bond(id);
        let (tail, head) = model.ends(id);
        let setter = causal.and_then(|c| c.effort_setter(model, id));
        let style = match bond.kind {
            BondKind::Signal => "arrowhead=normal, style=dashed",
            // The tail sets the effort: the head receives it, the stroke is at the head.
            BondKind::Power if setter == Some(tail) => "arrowhead=teelvee",
            BondKind::Power if setter == Some(head) => "dir=both, arrowtail=tee, arrowhead=lvee",
            BondKind::Power => "arrowhead=lvee",
        };
        let _ = writeln!(
            out,
            "  n{} -> n{} [label=\"{}\", {style}];",
            tail.0.index(),
            head.0.index(),
            bond.number
        );
    }
    out.push_str("}\n");
    out
}

/// A DOT string literal.
fn quote(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bonds_are_half_arrows_numbered_in_power_direction() {
        let (model, diagnostics) = bondgraph_core::load(
            "model rc\nparam R1 = 2\ninput U\nSe u = U\nR r = R1\nDf i on j\nu -[3]-> 1:j -> r\n",
        );
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let dot = emit(&model, None);
        assert!(dot.contains("n0 [label=\"Se:u\""), "{dot}");
        assert!(
            dot.contains("n0 -> n3 [label=\"3\", arrowhead=lvee]"),
            "{dot}"
        );
        assert!(
            dot.contains("n3 -> n1 [label=\"1\", arrowhead=lvee]"),
            "{dot}"
        );
        assert!(
            dot.contains("n3 -> n2 [label=\"2\", arrowhead=normal, style=dashed]"),
            "{dot}"
        );
    }

    #[test]
    fn causal_strokes_sit_where_the_effort_is_received() {
        let (model, _) = bondgraph_core::load(
            "model rc\nparam R1 = 2\nparam C1 = 1\ninput U\nSe u = U\nR r = R1\nC c = C1\nu -> 1:j -> r, c\n",
        );
        let model = model.expect("valid");
        let causal =
            bondgraph_core::causality::assign(&model, bondgraph_core::causality::Mode::Integral);
        let dot = emit(&model, Some(&causal));
        // Se imposes effort on the junction; C (integral) imposes effort on it too; R receives it.
        assert!(
            dot.contains("n0 -> n3 [label=\"1\", arrowhead=teelvee]"),
            "{dot}"
        );
        assert!(
            dot.contains("n3 -> n1 [label=\"2\", arrowhead=teelvee]"),
            "{dot}"
        );
        assert!(
            dot.contains("n3 -> n2 [label=\"3\", dir=both, arrowtail=tee, arrowhead=lvee]"),
            "{dot}"
        );
    }

    #[test]
    fn quotes_are_escaped() {
        assert_eq!(quote("a\"b\\"), "\"a\\\"b\\\\\"");
    }
}
