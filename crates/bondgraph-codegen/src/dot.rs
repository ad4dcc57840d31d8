//! Graphviz DOT of a bond graph: half-arrows along positive power, bond numbers, `KIND:name`.
//!
//! Signal bonds to detectors are drawn dashed with a full arrow, as activated bonds are in the
//! literature; the signals that modulate an element (a detector's, an input's) dotted, into it. Given a causality, each power bond also gets its causal stroke, at the end that
//! receives the effort. With ARRs, each element and detector is filled with the colour of its
//! fault class (the components the ARRs cannot tell apart share one; the first 8 colours of
//! the `pastel19` scheme, repeated past 8 classes, the class number in the tooltip: its 9th is
//! the light grey of what is undetectable), and what no ARR detects is left unfilled in grey. Output depends only on the model, so it is stable from run to run.

use std::fmt::Write as _;

/// Colours of `pastel19` the fault classes take in turn: the scheme's 9th, `#f2f2f2`, is a
/// grey that reads as "undetectable".
const CLASS_COLOURS: usize = 8;

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
    let classes = class_of(c);
    for (h, node) in g.nodes.iter() {
        let (label, mut tooltip) = match node.class {
            NodeClass::Junction(symbol) => (symbol.to_string(), node.name.clone()),
            NodeClass::Element(kind) => (format!("{kind}:{}", node.name), node.note.clone()),
            NodeClass::Sensor(kind) => {
                (format!("{}:{}", kind.name(), node.name), node.note.clone())
            }
        };
        let fill = match classes.get(node.name.as_str()) {
            Some(Some(k)) if !matches!(node.class, NodeClass::Junction(_)) => {
                let _ = write!(tooltip, " (fault class {})", k + 1);
                format!(
                    ", style=filled, fillcolor=\"/pastel19/{}\"",
                    k % CLASS_COLOURS + 1
                )
            }
            Some(None) if !matches!(node.class, NodeClass::Junction(_)) => {
                tooltip.push_str(" (no ARR detects it)");
                ", fontcolor=gray50".to_string()
            }
            _ => String::new(),
        };
        let _ = writeln!(
            out,
            "  n{} [label={}, tooltip={}{fill}];",
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
    modulations(c, &mut out);
    out.push_str("}\n");
    out
}

/// The signals that modulate elements, as activated bonds (dotted, full arrow) into them: a
/// detector's from its node, any other signal's (an input, a `let`, `t`) from a node of its
/// own named after it, drawn once.
fn modulations(c: &Compiled, out: &mut String) {
    let g = &c.graph;
    let detector = |name: &str| {
        (g.nodes.iter())
            .find(|(_, n)| n.name == name && matches!(n.class, NodeClass::Sensor(_)))
            .map(|(h, _)| h)
    };
    let mut drawn: Vec<&str> = Vec::new();
    for (h, node) in g.nodes.iter() {
        for signal in &node.modulation {
            let tail = match detector(signal) {
                Some(s) => format!("n{}", s.index()),
                None => {
                    let id = quote(&format!("signal:{signal}"));
                    if !drawn.contains(&signal.as_str()) {
                        drawn.push(signal);
                        let _ = writeln!(
                            out,
                            "  {id} [label={}, tooltip=\"signal\", fontcolor=gray30];",
                            quote(signal)
                        );
                    }
                    id
                }
            };
            let _ = writeln!(
                out,
                "  {tail} -> n{} [arrowhead=normal, style=dotted, tooltip={}];",
                h.index(),
                quote(&format!("{signal} modulates {}", node.name))
            );
        }
    }
}

/// Each component's fault class with the product's ARRs (`None`: undetectable), by name;
/// empty without ARRs.
fn class_of(c: &Compiled) -> std::collections::HashMap<&str, Option<usize>> {
    let mut out = std::collections::HashMap::new();
    if c.arrs.is_empty() {
        return out;
    }
    let selected = &c.isolability.selected;
    for (k, class) in selected.classes.iter().enumerate() {
        for &h in class {
            out.insert(c.components[h].name.as_str(), Some(k));
        }
    }
    for &h in &selected.undetectable {
        out.insert(c.components[h].name.as_str(), None);
    }
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

    /// A pump's impeller, a gyrator modulated by the measured speed, and a source modulated
    /// by an input: each modulating signal is an activated bond into its element, a
    /// detector's from the detector, an input's from a node of its own, drawn once.
    #[test]
    fn modulating_signals_are_drawn_into_their_elements() {
        let dot = emit(&compile(
            "model pump\nparam a = 0.5\nparam R1 = 2\ninput U\nMSe src = U*w\nMGY imp = a*w*U\n\
             R line = R1\nDf w on j\nsrc -> 1:j -> imp -> 1:k -> line\n",
            Derive::Nothing,
        ));
        let src = "n0 [label=\"MSe:src\"";
        let imp = "n1 [label=\"MGY:imp\"";
        let w = "n3 [label=\"Df:w\"";
        assert!(
            dot.contains(src) && dot.contains(imp) && dot.contains(w),
            "{dot}"
        );
        for element in [0, 1] {
            let edge = format!("  n3 -> n{element} [arrowhead=normal, style=dotted");
            assert!(dot.contains(&edge), "{edge} in {dot}");
            let edge = format!("  \"signal:U\" -> n{element} [arrowhead=normal, style=dotted");
            assert!(dot.contains(&edge), "{edge} in {dot}");
        }
        assert_eq!(dot.matches("\"signal:U\" [label=\"U\"").count(), 1, "{dot}");
        assert!(
            !dot.contains("-> n2 [arrowhead=normal, style=dotted"),
            "R is not modulated"
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

    /// The DC motor with its current and speed measured: with the ARRs, each component is
    /// filled with its class's colour and named by class in its tooltip; junctions are not.
    #[test]
    fn components_are_filled_by_fault_class() {
        let text = "model m\nparam R1 = 2\nparam L1 = 0.1\nparam J1 = 0.01\nparam k = 0.5\nparam b = 0.1\ninput U\n\
                    Se u = U\nR r = R1\nI l = L1\nGY g = k\nI j = J1\nR f = b\nDf i on e\nDf w on s\n\
                    u -> 1:e -> r, l\ne -> g -> 1:s -> j, f\n";
        let dot = emit(&compile(text, Derive::Everything));
        assert!(
            dot.contains("style=filled, fillcolor=\"/pastel19/"),
            "{dot}"
        );
        assert!(dot.contains("(fault class 1)"), "{dot}");
        let junction = dot
            .lines()
            .find(|l| l.contains("label=\"1\""))
            .expect("a junction");
        assert!(!junction.contains("fillcolor"), "{junction}");
        // Without ARRs, nothing is filled.
        let plain = emit(&compile(text, Derive::StateEquations));
        assert!(!plain.contains("fillcolor"), "{plain}");
    }

    /// A chain whose every mass is measured has more than 8 classes: none takes the grey of
    /// the undetectable (`pastel19`'s 9th colour), class 9 takes the first colour again.
    #[test]
    fn no_class_is_filled_with_the_grey_of_the_undetectable() {
        let text = bondgraph_core::generate::mass_spring_chain_varied(12, 1);
        let dot = emit(&compile(&text, Derive::Everything));
        assert!(dot.contains("(fault class 9)"), "{dot}");
        assert!(!dot.contains("/pastel19/9"), "{dot}");
        let nine = dot
            .lines()
            .find(|l| l.contains("(fault class 9)"))
            .expect("class 9");
        assert!(nine.contains("/pastel19/1\""), "{nine}");
    }

    #[test]
    fn quotes_are_escaped() {
        assert_eq!(quote("a\"b\\"), "\"a\\\"b\\\\\"");
    }
}
