//! The residual program: what a residual generator does with each sample, lowered once from
//! the product so that every backend runs the same thing. The Rust emitter prints it (the
//! generated `ResidualGenerator`); the interpreter crate runs it (`bgc residuals`, the
//! tests).
//!
//! Per sample, a generator:
//! 1. steps the copy of the model, if a simulated residual reads one, on the raw inputs;
//! 2. feeds the estimator bank its [`Channel`]s: raw signals, and the trapezoidal integrals
//!    of some of them;
//! 3. once the bank's windows are full, fills each [`Slot`] at the instant of the estimates:
//!    from an estimate, from the copy's state at that instant, or (in slot order) by
//!    integrating an expression of the slots filled before it;
//! 4. evaluates the residuals, straight-line expressions over the slots and the parameters,
//!    and takes the change of those realised by integration since their reference.
//!
//! Nothing in the expressions is an integral any more: each `int(..)` of the product is a
//! slot (or a combination of slots with parameter coefficients), each auxiliary signal is
//! its definition.

mod lower;
mod stability;

pub use stability::Stability;

use crate::index::typed_index;
use crate::product::{Arena, Handle, Parameter, Quantity, Signal};
use crate::symbolic::{ExprId, Pool};

typed_index! {
    /// A state of the copy of the model, by its place: the model's states, then the
    /// integrals the copy carries.
    pub struct CopyState;
}

typed_index! {
    /// An input of the copy, by its place in [`CopyRates::inputs`].
    pub struct CopyInput;
}

/// A leaf of the program's expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Leaf {
    /// A quantity estimated (or integrated, or simulated) from the samples.
    Slot(Handle<Slot>),
    /// A model parameter.
    Parameter(Handle<Parameter>),
    /// Time: the copy's rates may read it.
    Time,
    /// The copy's `k`-th state (its rates only): the model's states, then its integrals.
    State(CopyState),
    /// The copy's `j`-th input, in the order of [`CopyRates::inputs`] (its rates only).
    Input(CopyInput),
}

/// An expression of the program.
pub type Code = ExprId<Leaf>;

/// One raw signal a generator takes, in the order of its `push`.
#[derive(Clone, Debug, PartialEq)]
pub struct Raw {
    /// The input or measured signal.
    pub signal: Signal,
    /// Its name in the model.
    pub name: String,
    /// The highest derivative of it that the residuals read.
    pub order: u32,
}

/// What one channel of the estimator bank is fed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// A raw signal as sampled.
    Raw(Handle<Raw>),
    /// The trapezoidal integral of a raw signal from the first sample.
    Integral(Handle<Raw>),
}

/// One signal the estimator bank estimates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Channel {
    /// What it is fed.
    pub source: Source,
    /// The highest derivative read of it (0: its value only).
    pub order: u32,
}

/// How a slot gets its value at the instant of the estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fill {
    /// The bank's estimate of a channel's derivative.
    Estimate {
        /// The channel.
        channel: Handle<Channel>,
        /// The derivative's order (0: the value).
        order: u32,
    },
    /// The trapezoidal integral, over the instants of the estimates, of an expression of the
    /// slots before it.
    Integral(Code),
    /// A state of the copy of the model (its position in the copy's states).
    Simulated(CopyState),
    /// The root of `residual`, an expression of the slots before it and of this slot, found
    /// by Newton's method (with `slope`, its derivative in this slot) from the last sample's
    /// root, bisection where Newton fails (see `bondgraph::RootFinder`).
    Root {
        /// Zero at the root.
        residual: Code,
        /// Its derivative in the root.
        slope: Code,
    },
}

/// One quantity the residuals read: a field of the generated `Signals`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    /// What it is, in the product's terms.
    pub quantity: Quantity,
    /// How it is filled.
    pub fill: Fill,
}

/// How a residual's expression becomes the residual.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluation {
    /// The expression is the residual.
    Direct,
    /// The expression is a running value `F + ∫A`; the residual is its change since a
    /// reference instant (`bondgraph::Reference`).
    Integrated,
}

/// One residual.
#[derive(Clone, Debug, PartialEq)]
pub struct Residual {
    /// The ARR's name.
    pub name: String,
    /// What is evaluated.
    pub code: Code,
    /// How it becomes the residual.
    pub evaluation: Evaluation,
}

/// One sensitivity `∂r/∂θ` of a residual to an uncertain parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensitivity {
    /// The residual, by position.
    pub residual: usize,
    /// The parameter.
    pub parameter: Handle<Parameter>,
    /// `∂r/∂θ`.
    pub code: Code,
}

/// The copy of the model that simulated residuals run, integrated from rest on the raw
/// inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct CopyRates {
    /// Each state's rate: the model's state equations, then the argument of each integral
    /// they hold.
    pub rates: Vec<Code>,
    /// The states' names: the model's, then `int1`, `int2`…
    pub names: Vec<String>,
    /// The raw signals the rates read as [`Leaf::Input`]s, in order.
    pub inputs: Vec<Handle<Raw>>,
}

/// The residual program of a compiled model (see the module's documentation).
#[derive(Clone, Debug)]
pub struct Program {
    /// The raw signals, in the order a generator takes them.
    pub raw: Arena<Raw>,
    /// The bank's channels: the raw signals whose derivatives are read, the other raw
    /// signals, then the integrals.
    pub channels: Arena<Channel>,
    /// How many of the first channels need derivatives.
    pub differentiated: usize,
    /// The quantities the residuals read, in the order they are filled.
    pub slots: Arena<Slot>,
    /// Every expression of the program.
    pub code: Pool<Leaf>,
    /// The residuals, in the ARRs' order.
    pub residuals: Vec<Residual>,
    /// Every sensitivity of every residual, residual by residual.
    pub sensitivities: Vec<Sensitivity>,
    /// Expressions with a name of their own (the auxiliary signals the residuals read:
    /// `z1`, `z1_d1`…), which a backend may bind to that name.
    pub named: Vec<(Code, String)>,
    /// The copy of the model, when a simulated residual reads one.
    pub copy: Option<CopyRates>,
}

impl Program {
    /// The highest derivative any channel needs.
    pub fn top_order(&self) -> u32 {
        self.channels.values().map(|c| c.order).max().unwrap_or(0)
    }

    /// The slot holding `q`, if the residuals read it.
    pub fn slot(&self, q: Quantity) -> Option<Handle<Slot>> {
        self.slots.find(|s| s.quantity == q)
    }

    /// Every expression whose value the parameters may change: the residuals, the fills'
    /// integrands and laws, the copy's rates.
    pub fn parametrised(&self) -> Vec<Code> {
        let mut roots: Vec<Code> = self.residuals.iter().map(|r| r.code).collect();
        for slot in self.slots.values() {
            match slot.fill {
                Fill::Integral(code) => roots.push(code),
                Fill::Root { residual, .. } => roots.push(residual),
                Fill::Estimate { .. } | Fill::Simulated(_) => {}
            }
        }
        if let Some(copy) = &self.copy {
            roots.extend(copy.rates.iter().copied());
        }
        roots
    }

    /// The parameters the residuals depend on (through their own code, a fill's integrand or
    /// law, or the copy's rates), in the model's order: those a fault's size can be
    /// estimated of.
    pub fn parameters_read(&self) -> Vec<Handle<Parameter>> {
        let mut read = std::collections::BTreeSet::new();
        self.code.visit_reachable(&self.parametrised(), |_, node| {
            if let crate::symbolic::Node::Leaf(Leaf::Parameter(p)) = node {
                read.insert(p);
            }
        });
        read.into_iter().collect()
    }
}

/// How a program's expression depends on the slots.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Degree {
    /// Not at all: numbers and parameters.
    Constant,
    /// As `Σ cᵢ·slotᵢ + c₀` with constant `cᵢ`.
    Affine,
    /// Otherwise.
    Other,
}

impl Program {
    /// Whether every residual is affine in the estimated slots with constant coefficients,
    /// and reads no integral of a nonlinear expression and no copy of the model: then any
    /// linear filter applied alike to every signal leaves it exactly zero on a healthy plant.
    pub fn linear(&self) -> bool {
        let estimated = self
            .slots
            .values()
            .all(|s| matches!(s.fill, Fill::Estimate { .. }));
        let mut degree: std::collections::HashMap<Code, Degree> = Default::default();
        let roots: Vec<Code> = self.residuals.iter().map(|r| r.code).collect();
        self.code.visit_reachable(&roots, |id, node| {
            let of = |c: Code| degree.get(&c).copied().unwrap_or(Degree::Other);
            let d = node_degree(node, of);
            degree.insert(id, d);
        });
        estimated
            && self.copy.is_none()
            && roots
                .iter()
                .all(|r| degree.get(r).is_some_and(|&d| d != Degree::Other))
    }
}

/// A node's [`Degree`] from its children's.
fn node_degree(node: crate::symbolic::Node<Leaf>, of: impl Fn(Code) -> Degree) -> Degree {
    use crate::expr::BinOp;
    use crate::symbolic::Node;
    let max = |a: Degree, b: Degree| match (a, b) {
        (Degree::Other, _) | (_, Degree::Other) => Degree::Other,
        (Degree::Affine, _) | (_, Degree::Affine) => Degree::Affine,
        _ => Degree::Constant,
    };
    match node {
        Node::Num(_) | Node::Leaf(Leaf::Parameter(_)) => Degree::Constant,
        Node::Leaf(Leaf::Slot(_)) => Degree::Affine,
        Node::Leaf(_) | Node::Int(_) => Degree::Other,
        Node::Neg(a) => of(a),
        Node::Binary(BinOp::Add | BinOp::Sub, a, b) => max(of(a), of(b)),
        Node::Binary(BinOp::Mul, a, b) => match (of(a), of(b)) {
            (Degree::Constant, d) | (d, Degree::Constant) => d,
            _ => Degree::Other,
        },
        Node::Binary(BinOp::Div, a, b) if of(b) == Degree::Constant => of(a),
        // Powers and functions of constants are constants; of slots, not affine.
        Node::Binary(_, a, b) => match max(of(a), of(b)) {
            Degree::Constant => Degree::Constant,
            _ => Degree::Other,
        },
        Node::Call1(_, a) => match of(a) {
            Degree::Constant => Degree::Constant,
            _ => Degree::Other,
        },
        Node::Call2(_, a, b) => match max(of(a), of(b)) {
            Degree::Constant => Degree::Constant,
            _ => Degree::Other,
        },
    }
}

#[cfg(test)]
mod tests {
    use crate::{compile, Options, ResidualSet};

    fn program(text: &str, residuals: ResidualSet) -> super::Program {
        let options = Options {
            residuals,
            ..Options::default()
        };
        let c = compile(text, "test.bg", &options).expect("valid").compiled;
        assert!(!c.has_errors(), "{:?}", c.diagnostics);
        c.program()
    }

    /// A chain of masses, springs and dampers gives ARRs linear in the signals; the bench's
    /// dead zone does not, nor does a residual that runs a copy of the model.
    #[test]
    fn linear_programs_are_told_from_the_others() {
        let chain = include_str!("../../../../models/four_mass_chain.bg");
        assert!(program(chain, ResidualSet::PerSensor).linear());
        let bench = include_str!("../../../../models/backlash_bench.bg");
        assert!(!program(bench, ResidualSet::PerSensor).linear());
        assert!(!program(bench, ResidualSet::Best).linear());
        let motor = include_str!("../../../../models/dc_motor.bg");
        assert!(program(motor, ResidualSet::PerSensor).linear());
    }

    /// The program's slots are filled from the channels that carry their signal, and the
    /// bank differentiates only the channels whose derivatives are read, first.
    #[test]
    fn channels_put_the_differentiated_signals_first() {
        let bench = include_str!("../../../../models/backlash_bench.bg");
        let p = program(bench, ResidualSet::PerSensor);
        let orders: Vec<u32> = p.channels.values().map(|c| c.order).collect();
        assert!(
            orders[..p.differentiated].iter().all(|&n| n > 0),
            "{orders:?}"
        );
        assert!(
            orders[p.differentiated..].iter().all(|&n| n == 0),
            "{orders:?}"
        );
        for slot in p.slots.values() {
            if let super::Fill::Estimate { channel, order } = slot.fill {
                assert!(order <= p.channels[channel].order);
            }
        }
    }
}
