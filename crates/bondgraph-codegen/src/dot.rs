//! Graphviz DOT of a bond graph: half-arrows along positive power, bond numbers, `KIND:name`.
//!
//! Signal bonds to detectors are drawn dashed with a full arrow, as activated bonds are in the
//! literature. Given a causality, each power bond also gets its causal stroke, at the end that
//! receives the effort. Output depends only on the model, so it is stable from run to run.

use std::fmt::Write as _;

use bondgraph_core::{Compiled, NodeClass, Stroke};

/// The model as a DOT digraph, with the causal strokes of the simulation causality when it
/// was derived.
pub fn emit(c: &Compiled) -> String {
    let g = &c.graph;
    let mut out = String::new();
    let _ = writeln!(out, "digraph {} {{", quote(&c.name));
    let _ = writeln!(out, "  graph [rankdir=LR, fontname=\"Helvetica\"];");
    let _ = writeln!(
        out,
        "  node [shape=plaintext, fontname=\"Helvetica\"];\n  edge [fontname=\"Helvetica\", fontsize=10];"
    );
    for (h, node) in g.nodes.iter() {
        let (label, tooltip) = match node.class {
            NodeClass::Junction(symbol) => (symbol.to_string(), node.name.clone()),
            NodeClass::Element(kind) => (format!("{kind}:{}", node.name), node.note.clone()),
            NodeClass::Sensor(kind) => {
                (format!("{}:{}", kind.name(), node.name), node.note.clone())
            }
        };
        let _ = writeln!(
            out,
            "  n{} [label={}, tooltip={}];",
            h.index(),
            quote(&label),
            quote(&tooltip)
        );
    }
    for bond in &g.bonds {
        let style = match (bond.signal, bond.stroke) {
            (true, _) => "arrowhead=normal, style=dashed",
            // The tail sets the effort: the head receives it, the stroke is at the head.
            (false, Stroke::Head) => "arrowhead=teelvee",
            (false, Stroke::Tail) => "dir=both, arrowtail=tee, arrowhead=lvee",
            (false, Stroke::None) => "arrowhead=lvee",
        };
        let _ = writeln!(
            out,
            "  n{} -> n{} [label=\"{}\", {style}];",
            bond.tail.index(),
            bond.head.index(),
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
    use bondgraph_core::{Derive, Options};

    fn compile(text: &str, derive: Derive) -> Compiled {
        let options = Options {
            derive,
            simplify: None,
            ..Options::default()
        };
        match bondgraph_core::compile(text, "test.bg", &options) {
            Ok(out) => out.compiled,
            Err(d) => panic!("{d:?}"),
        }
    }

    #[test]
    fn bonds_are_half_arrows_numbered_in_power_direction() {
        let dot = emit(&compile(
            "model rc\nparam R1 = 2\ninput U\nSe u = U\nR r = R1\nDf i on j\nu -[3]-> 1:j -> r\n",
            Derive::Nothing,
        ));
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
        let dot = emit(&compile(
            "model rc\nparam R1 = 2\nparam C1 = 1\ninput U\nSe u = U\nR r = R1\nC c = C1\nu -> 1:j -> r, c\n",
            Derive::StateEquations,
        ));
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
