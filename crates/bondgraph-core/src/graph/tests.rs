//! Lowering checked on small models whose graph a person can draw by hand.

use petgraph::Direction::{Incoming, Outgoing};

use super::*;
use crate::diagnostic::Code;

fn lowered(text: &str) -> BondGraph {
    let (graph, diagnostics) = crate::graph::load(text);
    graph.unwrap_or_else(|| panic!("{diagnostics:#?}"))
}

fn codes(text: &str) -> Vec<Code> {
    let (graph, diagnostics) = crate::graph::load(text);
    assert!(graph.is_none(), "expected a rejection");
    diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| d.code)
        .collect()
}

fn node(model: &BondGraph, name: &str) -> NodeId {
    model
        .nodes()
        .find(|&n| model.node(n).name == name)
        .unwrap_or_else(|| panic!("no node {name}"))
}

fn law(model: &BondGraph, name: &str) -> String {
    match &model.node(node(model, name)).kind {
        NodeKind::Element(_, law) => model.show(law.expr()),
        other => panic!("{name} is {other:?}"),
    }
}

const RLC: &str = "model rlc\nparam R1 = 2\nparam L1 = 3\nparam C1 = 4\ninput V\n\
    Se s = V\nR r = R1\nI l = L1\nC c = C1\nDf i on loop\ns -> 1:loop -> r, l\nloop -[9]-> c\n";

#[test]
fn linear_laws_are_normalised() {
    let m = lowered(RLC);
    assert_eq!(law(&m, "r"), "R1");
    assert_eq!(law(&m, "l"), "1 / L1");
    assert_eq!(law(&m, "c"), "1 / C1");
    assert_eq!(law(&m, "s"), "V");
    let m = lowered(
        "model g\nparam N = 5\nparam K = 2\nSe s = 1\nTF g ratio N\nC k stiffness K\n\
         R r = 1\ns -> 1:a -> g -> 0:b -> k, r\nSe s2 = 1\ns2 -> a\n",
    );
    assert_eq!(law(&m, "g"), "1 / N");
    assert_eq!(law(&m, "k"), "K");
}

#[test]
fn bonds_follow_power_and_fill_numbers_around_explicit_ones() {
    let m = lowered(RLC);
    let by_number = |n: u32| {
        let b = m.bonds().find(|&b| m.bond(b).number == n).expect("bond");
        let (t, h) = m.ends(b);
        (
            m.node(t).name.clone(),
            m.node(h).name.clone(),
            m.bond(b).kind,
        )
    };
    assert_eq!(by_number(1), ("s".into(), "loop".into(), BondKind::Power));
    assert_eq!(by_number(2), ("loop".into(), "r".into(), BondKind::Power));
    assert_eq!(by_number(3), ("loop".into(), "l".into(), BondKind::Power));
    assert_eq!(by_number(9), ("loop".into(), "c".into(), BondKind::Power));
    assert_eq!(by_number(4), ("loop".into(), "i".into(), BondKind::Signal));
    let loop_ = node(&m, "loop");
    assert_eq!(m.bonds_at(loop_, Incoming).len(), 1);
    assert_eq!(m.bonds_at(loop_, Outgoing).len(), 4);
    assert_eq!(
        m.counts(),
        Counts {
            elements: 4,
            bonds: 5,
            junctions: 1,
            detectors: 1
        }
    );
}

#[test]
fn backward_arrows_reverse_power() {
    let m = lowered("model b\nSe s = 1\nR r = 1\nr <- 1:j <- s\n");
    let b = m.bonds().next().expect("bond");
    let (t, h) = m.ends(b);
    assert_eq!(
        (m.node(t).name.as_str(), m.node(h).name.as_str()),
        ("j", "r")
    );
}

#[test]
fn explicit_laws_name_their_port_variable() {
    let m = lowered("model t\nparam a = 2\nSf p = 1\nR o : f = a*sqrt(abs(e))\nC c : e = q^3\np -> 0:j -> o, c\n");
    assert_eq!(law(&m, "o"), "a * sqrt(abs(e))");
    assert_eq!(law(&m, "c"), "q ^ 3");
    assert_eq!(
        codes("model t\nSf p = 1\nR o : f = f\nC c = 1\np -> 0:j -> o, c\n"),
        [Code::BadReference]
    );
    assert_eq!(
        codes("model t\nSf p = 1\nR o : q = e\nC c = 1\np -> 0:j -> o, c\n"),
        [Code::BadLaw]
    );
}

#[test]
fn lets_are_ordered_after_what_they_use_and_cycles_rejected() {
    let m = lowered("model l\nlet b = a + 1\nlet a = 2*t\nMSe s = b\nR r = 1\ns -> r\n");
    let order: Vec<&str> = m
        .let_order
        .iter()
        .map(|id| m.lets[id.index()].name.as_str())
        .collect();
    assert_eq!(order, ["a", "b"]);
    assert_eq!(
        codes("model l\nlet a = b\nlet b = c\nlet c = a\nMSe s = a\nR r = 1\ns -> r\n"),
        [Code::Cycle]
    );
}

#[test]
fn what_an_expression_may_use_depends_on_where_it_stands() {
    let base =
        "model c\ninput u\nparam k = 1\nDf y on j\nR r = 1\nSe s2 = 1\ns2 -> 1:j -> r\ns -> j\n";
    assert_eq!(codes(&format!("{base}Se s = y\n")), [Code::BadReference]);
    assert!(crate::graph::load(&format!("{base}Se s = u*sin(t)\n"))
        .0
        .is_some());
    assert!(crate::graph::load(&format!("{base}MSe s = y*k\n"))
        .0
        .is_some());
    assert_eq!(
        codes("model c\ninput u\nSe s = 1\nTF g = u\nR r = 1\nR q = 1\ns -> 1:a -> g -> 1:b -> r\na -> q\n"),
        [Code::BadReference]
    );
}

#[test]
fn structure_is_checked_per_kind() {
    assert_eq!(
        codes("model s\nSe s = 1\nR r = 1\nr -> s\n"),
        [Code::Direction, Code::Direction]
    );
    assert_eq!(
        codes("model s\nSe s = 1\nR r = 1\nR q = 1\ns -> r\ns -> q\n"),
        [Code::PortCount]
    );
    assert_eq!(
        codes(
            "model s\nSe s = 1\nTF g = 2\nR r = 1\nR q = 1\ns -> 1:a -> g -> r\na -> q\ng -> 0:x\n"
        ),
        [Code::PortCount, Code::PortCount]
    );
    assert_eq!(
        codes("model s\nDe y on j\nSe s = 1\nR r = 1\ns -> 1:j -> r\n"),
        [Code::Detector]
    );
    assert_eq!(
        codes("model s\nDf y\nSe s = 1\nR r = 1\ns -> 1:j -> r\n"),
        [Code::PortCount]
    );
    assert_eq!(
        codes("model s\nDf y\nSe s = 1\nR r = 1\ns -> 1:j -> r\ny -> j\n"),
        [Code::Direction]
    );
}

const FAULTY_RLC: &str = "model rlc\nparam R1 = 2\nparam L1 = 3\nparam C1 = 4\ninput V\n\
    param kv = 1\nparam ib = 0\nparam ig = 1\nparam id = 0\n\
    Se s = V with gain = kv\nR r = R1\nI l = L1\nC c = C1\n\
    Df i on loop with bias = ib, gain = ig, drift = id\ns -> 1:loop -> r, l\nloop -[9]-> c\n";

#[test]
fn sensors_and_sources_carry_their_faults_as_parameters() {
    let m = lowered(FAULTY_RLC);
    let param = |name: &str| {
        let k = m.params.iter().position(|p| p.name == name).expect("param");
        ParamId(k as u32)
    };
    let i = &m.node(node(&m, "i")).faults;
    assert_eq!(i.get(Carried::Bias), Some(param("ib")));
    assert_eq!(i.get(Carried::Gain), Some(param("ig")));
    assert_eq!(i.get(Carried::Drift), Some(param("id")));
    assert_eq!(
        m.node(node(&m, "s")).faults.get(Carried::Gain),
        Some(param("kv"))
    );
    assert!(m.node(node(&m, "r")).faults.0.is_empty());
}

#[test]
fn a_fault_clause_is_checked_word_by_word() {
    let with = |from: &str, to: &str| codes(&FAULTY_RLC.replace(from, to));
    // A source has no drift, a detector no offset, an `R` no fault clause at all.
    assert_eq!(
        with("V with gain = kv", "V with drift = kv"),
        [Code::BadLaw]
    );
    assert_eq!(with("drift = id", "offset = id"), [Code::BadLaw]);
    assert_eq!(with("R r = R1", "R r = R1 with gain = kv"), [Code::BadLaw]);
    // Each fault once, each bound to a parameter.
    assert_eq!(with("drift = id", "gain = id"), [Code::Duplicate]);
    assert_eq!(with("gain = kv", "gain = V"), [Code::BadReference]);
    assert_eq!(with("gain = kv", "gain = nowhere"), [Code::BadReference]);
}

#[test]
fn with_stays_a_name_outside_the_clause() {
    let m = lowered(
        &RLC.replace("param R1 = 2", "param with = 2")
            .replace("R r = R1", "R r = with"),
    );
    assert_eq!(law(&m, "r"), "with");
}
