//! The bond graph a model describes: nodes and bonds in a petgraph, signals in typed tables.
//!
//! Everything here is resolved: names are ids, laws are normalised, bonds are numbered. Spans
//! stay attached so later stages can still point at the source.

use crate::index::typed_index;
use petgraph::graph::{DiGraph, EdgeIndex, NodeIndex};
use petgraph::visit::EdgeRef;
use petgraph::Direction;

use crate::diagnostic::Span;
use crate::expr::Expr;
pub(crate) use crate::syntax::ast::JunctionKind;

/// A node of the graph: an element, a junction or a detector.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(pub NodeIndex);

/// A bond of the graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct BondId(pub EdgeIndex);

typed_index! {
    /// A parameter, by its place in [`BondGraph::params`].
    pub struct ParamId;
}

typed_index! {
    /// An input, by its place in [`BondGraph::inputs`].
    pub struct InputId;
}

typed_index! {
    /// A `let` definition, by its place in [`BondGraph::lets`].
    pub(crate) struct LetId;
}

/// What a name in an expression stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Signal {
    /// A constant parameter.
    Param(ParamId),
    /// A known input signal.
    Input(InputId),
    /// A named helper expression.
    Let(LetId),
    /// The signal a detector measures.
    Sensor(NodeId),
    /// Time, `t`.
    Time,
    /// A port variable of the element whose law this is (`e`, `f`, `p`, `q`).
    Port(PortVar),
}

/// The variables at an element's port, usable in its own law.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum PortVar {
    /// Effort.
    E,
    /// Flow.
    F,
    /// Momentum, the integral of effort (the state of an `I`).
    P,
    /// Displacement, the integral of flow (the state of a `C`).
    Q,
}

impl PortVar {
    /// The name as written in a law.
    pub(crate) fn name(self) -> &'static str {
        match self {
            PortVar::E => "e",
            PortVar::F => "f",
            PortVar::P => "p",
            PortVar::Q => "q",
        }
    }

    /// The port variable called `name`, if any.
    pub(crate) fn from_name(name: &str) -> Option<PortVar> {
        match name {
            "e" => Some(PortVar::E),
            "f" => Some(PortVar::F),
            "p" => Some(PortVar::P),
            "q" => Some(PortVar::Q),
            _ => None,
        }
    }
}

/// An expression over resolved signals.
pub(crate) type SignalExpr = Expr<Signal>;

/// A constant parameter.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Param {
    /// Its name.
    pub name: String,
    /// Its nominal value.
    pub value: f64,
    /// Its unit, as written.
    pub unit: Option<String>,
    /// How far the true value may be from the nominal one (a half-width, in its unit).
    pub uncertainty: Option<f64>,
    /// Whether it is marked `shared`: read by several components on purpose.
    pub shared: bool,
    /// What it is.
    pub description: Option<String>,
    /// Where it is declared.
    pub span: Span,
}

/// A known input signal (a voltage command, a pump flow…).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Input {
    /// Its name.
    pub name: String,
    /// Its unit, as written.
    pub unit: Option<String>,
    /// What it is.
    pub description: Option<String>,
    /// Where it is declared.
    pub span: Span,
}

/// A named helper expression.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Let {
    /// Its name.
    pub name: String,
    /// Its definition.
    pub value: SignalExpr,
    /// Where it is declared.
    pub span: Span,
}

/// The element kinds of the language.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[allow(clippy::upper_case_acronyms)] // MTF, MGY: the names every bond-graph text uses
pub(crate) enum ElementKind {
    /// Effort source.
    Se,
    /// Flow source.
    Sf,
    /// Modulated effort source.
    MSe,
    /// Modulated flow source.
    MSf,
    /// Resistor (dissipation).
    R,
    /// Capacitor (potential energy).
    C,
    /// Inertia (kinetic energy).
    I,
    /// Transformer.
    TF,
    /// Gyrator.
    GY,
    /// Modulated transformer.
    MTF,
    /// Modulated gyrator.
    MGY,
    /// Modulated resistor: its law may read inputs, measured signals and `t`.
    MR,
    /// Modulated capacitor: its law may read inputs, measured signals and `t`.
    MC,
    /// Modulated inertia: its law may read inputs, measured signals and `t`.
    MI,
}

impl ElementKind {
    /// Every kind, in the order the docs list them.
    pub(crate) const ALL: [ElementKind; 14] = [
        ElementKind::Se,
        ElementKind::Sf,
        ElementKind::MSe,
        ElementKind::MSf,
        ElementKind::R,
        ElementKind::C,
        ElementKind::I,
        ElementKind::TF,
        ElementKind::GY,
        ElementKind::MTF,
        ElementKind::MGY,
        ElementKind::MR,
        ElementKind::MC,
        ElementKind::MI,
    ];

    /// The name as written.
    pub(crate) fn name(self) -> &'static str {
        match self {
            ElementKind::Se => "Se",
            ElementKind::Sf => "Sf",
            ElementKind::MSe => "MSe",
            ElementKind::MSf => "MSf",
            ElementKind::R => "R",
            ElementKind::C => "C",
            ElementKind::I => "I",
            ElementKind::TF => "TF",
            ElementKind::GY => "GY",
            ElementKind::MTF => "MTF",
            ElementKind::MGY => "MGY",
            ElementKind::MR => "MR",
            ElementKind::MC => "MC",
            ElementKind::MI => "MI",
        }
    }

    /// The kind whose equations this one has: `R` for `MR`, `C` for `MC`, `I` for `MI`,
    /// itself otherwise (a modulated source or two-port keeps its own kind).
    pub(crate) fn base(self) -> ElementKind {
        match self {
            ElementKind::MR => ElementKind::R,
            ElementKind::MC => ElementKind::C,
            ElementKind::MI => ElementKind::I,
            k => k,
        }
    }

    /// Whether its law may read inputs, measured signals and `t`.
    pub(crate) fn is_modulated(self) -> bool {
        matches!(
            self,
            ElementKind::MSe
                | ElementKind::MSf
                | ElementKind::MTF
                | ElementKind::MGY
                | ElementKind::MR
                | ElementKind::MC
                | ElementKind::MI
        )
    }

    /// `C`, `I` and their modulated forms: elements that store energy.
    pub(crate) fn is_storage(self) -> bool {
        matches!(self.base(), ElementKind::C | ElementKind::I)
    }

    /// The kind called `name`, if any.
    pub(crate) fn from_name(name: &str) -> Option<ElementKind> {
        ElementKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Sources: one bond, pointing out.
    pub(crate) fn is_source(self) -> bool {
        matches!(
            self,
            ElementKind::Se | ElementKind::Sf | ElementKind::MSe | ElementKind::MSf
        )
    }

    /// TF, GY and their modulated forms: one bond in, one out.
    pub(crate) fn is_two_port(self) -> bool {
        matches!(
            self,
            ElementKind::TF | ElementKind::GY | ElementKind::MTF | ElementKind::MGY
        )
    }
}

/// The detector kinds: a junction's common variable, or its integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum DetectorKind {
    /// Measures the effort of a 0-junction.
    De,
    /// Measures the flow of a 1-junction.
    Df,
    /// Measures the integral of a 1-junction's flow: an encoder's angle, a displacement, a
    /// volume.
    Dq,
    /// Measures the integral of a 0-junction's effort: a momentum, a flux linkage.
    Dp,
}

impl DetectorKind {
    /// The name as written.
    pub(crate) fn name(self) -> &'static str {
        match self {
            DetectorKind::De => "De",
            DetectorKind::Df => "Df",
            DetectorKind::Dq => "Dq",
            DetectorKind::Dp => "Dp",
        }
    }

    /// The kind called `name`, if any.
    pub(crate) fn from_name(name: &str) -> Option<DetectorKind> {
        match name {
            "De" => Some(DetectorKind::De),
            "Df" => Some(DetectorKind::Df),
            "Dq" => Some(DetectorKind::Dq),
            "Dp" => Some(DetectorKind::Dp),
            _ => None,
        }
    }

    /// Every kind, in the order the language reference lists them.
    pub(crate) const ALL: [DetectorKind; 4] = [
        DetectorKind::De,
        DetectorKind::Df,
        DetectorKind::Dq,
        DetectorKind::Dp,
    ];

    /// How many times the junction's common variable is differentiated to give it: 1 for
    /// `Dq` and `Dp`, whose signal is that variable's integral.
    pub(crate) fn integrals(self) -> u32 {
        match self {
            DetectorKind::De | DetectorKind::Df => 0,
            DetectorKind::Dq | DetectorKind::Dp => 1,
        }
    }

    /// The junction kind whose common variable this detector reads.
    pub(crate) fn junction(self) -> JunctionKind {
        match self {
            DetectorKind::De | DetectorKind::Dp => JunctionKind::Zero,
            DetectorKind::Df | DetectorKind::Dq => JunctionKind::One,
        }
    }
}

/// The constitutive law of an element, normalised.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Law {
    /// A source's value: the effort of `Se`/`MSe`, the flow of `Sf`/`MSf`.
    Source(SignalExpr),
    /// A linear one-port with coefficient `x`: `R`: e = x·f; `C`: e = x·q; `I`: f = x·p.
    Linear(SignalExpr),
    /// A law given explicitly: `output = rhs`, the rhs in the element's other port variable.
    Explicit {
        /// The variable the law defines.
        output: PortVar,
        /// Its definition.
        rhs: SignalExpr,
    },
    /// The modulus of a two-port: `TF`: e1 = m·e2, f2 = m·f1; `GY`: e1 = r·f2, e2 = r·f1.
    Modulus(SignalExpr),
}

impl Law {
    /// The expression the law is made of.
    pub(crate) fn expr(&self) -> &SignalExpr {
        match self {
            Law::Source(x) | Law::Linear(x) | Law::Modulus(x) => x,
            Law::Explicit { rhs, .. } => rhs,
        }
    }
}

/// What a node is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum NodeKind {
    /// A 0- or 1-junction.
    Junction(JunctionKind),
    /// An element and its law.
    Element(ElementKind, Law),
    /// A detector; its name is the name of the signal it measures.
    Detector(DetectorKind),
}

/// A fault a detector or a source carries, as its `with` clause states it: each is a
/// parameter of the model whose nominal value is the healthy one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Carried {
    /// A detector's bias: it reads `gain·x + bias + drift·t` for the junction's `x`.
    Bias,
    /// A detector's or a source's gain (a source applies `gain·value + offset`).
    Gain,
    /// A detector's drift, a bias that grows with time (per second).
    Drift,
    /// A source's offset: what it applies beside its value.
    Offset,
}

impl Carried {
    /// The word of the `with` clause.
    pub fn name(self) -> &'static str {
        match self {
            Carried::Bias => "bias",
            Carried::Gain => "gain",
            Carried::Drift => "drift",
            Carried::Offset => "offset",
        }
    }

    /// The fault called `name`, if any.
    pub(crate) fn from_name(name: &str) -> Option<Carried> {
        Some(match name {
            "bias" => Carried::Bias,
            "gain" => Carried::Gain,
            "drift" => Carried::Drift,
            "offset" => Carried::Offset,
            _ => return None,
        })
    }

    /// What it does to what the component measures or applies.
    pub fn describe(self, sensor: bool) -> &'static str {
        match (self, sensor) {
            (Carried::Bias, _) => "sensor bias",
            (Carried::Gain, true) => "sensor gain",
            (Carried::Gain, false) => "actuator gain",
            (Carried::Drift, _) => "sensor drift",
            (Carried::Offset, _) => "actuator offset",
        }
    }
}

/// The faults a node carries, by parameter; empty for most nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Faults(pub Vec<(Carried, ParamId)>);

impl Faults {
    /// The parameter of `fault`, if the node carries it.
    pub(crate) fn get(&self, fault: Carried) -> Option<ParamId> {
        self.0.iter().find(|(f, _)| *f == fault).map(|(_, p)| *p)
    }
}

/// A node with its name.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Node {
    /// Its name.
    pub name: String,
    /// What it is.
    pub kind: NodeKind,
    /// The faults it carries (`with`): detectors and sources only.
    pub faults: Faults,
    /// What it is for, as the user described it.
    pub description: Option<String>,
    /// Where it is declared (for a junction: its first mention).
    pub span: Span,
}

impl Node {
    /// The junction kind, if this node is a junction.
    pub(crate) fn junction_kind(&self) -> Option<JunctionKind> {
        match self.kind {
            NodeKind::Junction(k) => Some(k),
            _ => None,
        }
    }

    /// Whether this node is a 0- or 1-junction.
    pub(crate) fn is_junction(&self) -> bool {
        self.junction_kind().is_some()
    }
}

/// Whether a bond carries power or only information.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum BondKind {
    /// A power bond: effort and flow, power positive along the half-arrow.
    Power,
    /// An activated bond from a junction to a detector: a measurement, no power.
    Signal,
}

/// A bond, directed along positive power (from `tail` to `head` in the graph).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Bond {
    /// Its number, as shown on drawings and used in equations.
    pub number: u32,
    /// Power or signal.
    pub kind: BondKind,
    /// The arrow that made it.
    pub span: Span,
}

/// A whole model: its signals and its graph.
#[derive(Clone, Debug)]
pub(crate) struct BondGraph {
    /// The model's name.
    pub name: String,
    /// Parameters, in declaration order.
    pub params: Vec<Param>,
    /// Inputs, in declaration order.
    pub inputs: Vec<Input>,
    /// `let` definitions, in declaration order.
    pub lets: Vec<Let>,
    /// The `let` definitions in an order where each comes after those it uses.
    pub let_order: Vec<LetId>,
    /// Nodes and bonds; edges point along positive power.
    pub graph: DiGraph<Node, Bond>,
}

impl BondGraph {
    /// The node `id`.
    pub(crate) fn node(&self, id: NodeId) -> &Node {
        &self.graph[id.0]
    }

    /// The bond `id`.
    pub(crate) fn bond(&self, id: BondId) -> &Bond {
        &self.graph[id.0]
    }

    /// Every node, in declaration order.
    pub(crate) fn nodes(&self) -> impl Iterator<Item = NodeId> + '_ {
        self.graph.node_indices().map(NodeId)
    }

    /// Every bond, in the order the chains wrote them.
    pub(crate) fn bonds(&self) -> impl Iterator<Item = BondId> + '_ {
        self.graph.edge_indices().map(BondId)
    }

    /// The two ends of a bond, in power direction.
    pub(crate) fn ends(&self, id: BondId) -> (NodeId, NodeId) {
        let (a, b) = self
            .graph
            .edge_endpoints(id.0)
            .expect("a BondId always names a bond of its own graph");
        (NodeId(a), NodeId(b))
    }

    /// The bonds at a node whose power flows into it (`Incoming`) or out of it (`Outgoing`).
    pub(crate) fn bonds_at(&self, node: NodeId, direction: Direction) -> Vec<BondId> {
        let mut bonds: Vec<BondId> = self
            .graph
            .edges_directed(node.0, direction)
            .map(|e| BondId(e.id()))
            .collect();
        bonds.sort();
        bonds
    }

    /// The junction a detector is attached to (`None` for other nodes, or an unattached one).
    pub(crate) fn detector_junction(&self, detector: NodeId) -> Option<NodeId> {
        if !matches!(self.node(detector).kind, NodeKind::Detector(_)) {
            return None;
        }
        let bond = self
            .bonds_at(detector, Direction::Incoming)
            .into_iter()
            .next()?;
        Some(self.ends(bond).0)
    }

    /// The name of a signal.
    pub(crate) fn signal_name(&self, signal: Signal) -> &str {
        match signal {
            Signal::Param(p) => &self.params[p.index()].name,
            Signal::Input(u) => &self.inputs[u.index()].name,
            Signal::Let(l) => &self.lets[l.index()].name,
            Signal::Sensor(node) => &self.node(node).name,
            Signal::Time => "t",
            Signal::Port(var) => var.name(),
        }
    }

    /// An expression as the user would write it.
    pub(crate) fn show(&self, expr: &SignalExpr) -> String {
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = expr.write_with(&mut out, &|s| self.signal_name(*s).to_string());
        out
    }

    /// Counts of what the model holds, for `bgc check`.
    #[cfg(test)]
    pub(crate) fn counts(&self) -> Counts {
        let mut counts = Counts::default();
        for node in self.graph.node_weights() {
            match node.kind {
                NodeKind::Junction(_) => counts.junctions += 1,
                NodeKind::Element(..) => counts.elements += 1,
                NodeKind::Detector(_) => counts.detectors += 1,
            }
        }
        counts.bonds = self.graph.edge_count();
        counts
    }
}

/// How many of each thing a model holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg(test)]
pub(crate) struct Counts {
    /// Elements (sources, R, C, I, TF, GY and modulated forms).
    pub elements: usize,
    /// Bonds, power and signal.
    pub bonds: usize,
    /// 0- and 1-junctions.
    pub junctions: usize,
    /// Detectors.
    pub detectors: usize,
}
