//! The product of compilation: what a user asked for and nothing of how it was found.
//!
//! [`Compiled`] is the one thing the emitters, the CLI and (later) the Rust generator and the
//! macro read. Its expressions live in one pool whose leaves are [`Symbol`]s, final names
//! only: a parameter, an input or a measured signal with its derivative order, a state, time.
//! Solver unknowns never get here; an expression that still held one, or a number that is not
//! finite, is refused when the product is built, with a diagnostic.

mod arena;
mod build;
mod readings;
mod realise;
mod uncertainty;

pub use arena::{Arena, Handle};
pub(crate) use build::build;
pub use readings::{LinearTerm, ModelCopy, Quantity, Readings};
pub(crate) use realise::realise;
pub use realise::time_rate;

use crate::diagnostic::{Diagnostics, LineCol, LineIndex, Span};
pub use crate::graph::Carried;
use crate::symbolic::{ExprId, Pool};

/// A leaf of a product expression: a name the user gave, never a solver's unknown.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Symbol {
    /// A parameter.
    Parameter(Handle<Parameter>),
    /// The n-th time derivative of an input (0: the input itself).
    Input(Handle<Input>, u32),
    /// The n-th time derivative of a measured signal (0: the signal itself).
    Sensor(Handle<Sensor>, u32),
    /// A state variable (in state equations and outputs, and in simulated residuals: the
    /// state of their copy of the model).
    State(Handle<State>),
    /// The n-th time derivative of an auxiliary signal (in ARRs only).
    Auxiliary(Handle<Auxiliary>, u32),
    /// Time.
    Time,
    /// An unknown of a nonlinear algebraic loop (in state equations and outputs only): set
    /// by its [`LoopUnknown::residual`]` = 0`, solved numerically when simulating.
    Loop(Handle<LoopUnknown>),
    /// The n-th time derivative of a variable set by a law with no closed-form inverse (in
    /// ARRs only): the root of its [`Root::residual`], found numerically by a residual
    /// generator at each sample; its derivatives are [`Root::derivatives`].
    Root(Handle<Root>, u32),
}

/// An expression of the product, a handle into [`Compiled::exprs`].
pub type Expr = ExprId<Symbol>;

/// The product's expression pool: hash-consed, so shared subexpressions stay shared.
pub type Exprs = Pool<Symbol>;

/// A model parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Its name.
    pub name: String,
    /// Its nominal value.
    pub value: f64,
    /// Its unit as written, e.g. `Ohm`.
    pub unit: Option<String>,
    /// How far the true value may be from the nominal one (`+- 5%` in the model), as a
    /// half-width in its unit: what adaptive thresholds allow for.
    pub uncertainty: Option<f64>,
    /// Whether the model marks it `shared`: several components read it on purpose (a gear
    /// ratio), and a change of it is not warned about.
    pub shared: bool,
    /// The sensor or actuator fault it stands for, if a detector's or a source's `with`
    /// names it: held at its healthy value when a model is identified, sized with the rest.
    pub carried: Option<CarriedFault>,
    /// What it is, as the user described it.
    pub description: Option<String>,
    /// Where it is declared.
    pub span: Span,
}

/// A parameter that stands for a fault a detector or a source carries (`with bias = qb`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CarriedFault {
    /// Which fault.
    pub fault: Carried,
    /// The detector or source that carries it.
    pub by: String,
    /// Whether that is a detector (a sensor fault) rather than a source (an actuator's).
    pub sensor: bool,
}

impl CarriedFault {
    /// `sensor gain of q`, `actuator offset of drive`.
    pub fn describe(&self) -> String {
        format!("{} of {}", self.fault.describe(self.sensor), self.by)
    }
}

/// A known input signal.
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// Its name.
    pub name: String,
    /// Its unit as written.
    pub unit: Option<String>,
    /// What it is.
    pub description: Option<String>,
    /// Where it is declared.
    pub span: Span,
}

/// What a detector measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SensorKind {
    /// `De`: the effort of a 0-junction.
    Effort,
    /// `Df`: the flow of a 1-junction.
    Flow,
    /// `Dq`: the integral of a 1-junction's flow (an angle, a position, a volume).
    Displacement,
    /// `Dp`: the integral of a 0-junction's effort (a momentum, a flux linkage).
    Momentum,
}

impl SensorKind {
    /// `De`, `Df`, `Dq` or `Dp`.
    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Effort => "De",
            SensorKind::Flow => "Df",
            SensorKind::Displacement => "Dq",
            SensorKind::Momentum => "Dp",
        }
    }
}

/// A detector; its name is the measured signal's name.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    /// The signal's name.
    pub name: String,
    /// Effort or flow.
    pub kind: SensorKind,
    /// The junction it is attached to.
    pub junction: String,
    /// What it measures, as the user described it.
    pub description: Option<String>,
    /// Where it is declared.
    pub span: Span,
}

/// Which energy variable a state is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StateKind {
    /// The momentum `p` of an `I`.
    Momentum,
    /// The displacement `q` of a `C`.
    Displacement,
    /// The effort `e` of a `C` whose law gives `q` from `e` with no closed-form inverse.
    Effort,
    /// The flow `f` of an `I` whose law gives `p` from `f` with no closed-form inverse.
    Flow,
    /// What a `Dq` or `Dp` detector measures: the integral of its junction's common variable.
    Measured,
}

/// A state variable of the simulation model.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// `p_NAME` or `q_NAME`; `e_NAME` or `f_NAME` for a co-energy state.
    pub name: String,
    /// The storage element's name (the detector's, for a measured integral).
    pub element: String,
    /// Which variable of the element it is.
    pub kind: StateKind,
    /// The detector whose partial copy holds it (see [`PartialCopy`]); `None` for the
    /// model's own states, which come first.
    pub copy: Option<Handle<Sensor>>,
}

/// A copy of the part of the model that the other detectors' measured signals drive, run
/// for one detector's simulated residual: its states' equations read those signals where
/// the model's would read the states they measure.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialCopy {
    /// The detector whose reading its output is compared with.
    pub sensor: Handle<Sensor>,
    /// The detectors whose measurements drive it.
    pub imposed: Vec<Handle<Sensor>>,
    /// One right-hand side per state of the copy (states of [`Compiled::states`] whose
    /// `copy` is `sensor`), in order.
    pub equations: Vec<(Handle<State>, Expr)>,
    /// What the copy gives for `sensor`'s reading.
    pub output: Expr,
}

/// The model in state-space form: `d(state)/dt = rhs` and each detector's output, with
/// the unknowns of nonlinear algebraic loops, if any, held implicitly.
#[derive(Clone, Debug, PartialEq)]
pub struct StateSpace {
    /// One right-hand side per state, in [`Compiled::states`] order.
    pub equations: Vec<(Handle<State>, Expr)>,
    /// Each detector's output over states and inputs.
    pub outputs: Vec<(Handle<Sensor>, Expr)>,
    /// The unknowns of nonlinear algebraic loops the right-hand sides and outputs read
    /// ([`Symbol::Loop`]); empty when the state equations are explicit.
    pub loops: Vec<LoopUnknown>,
    /// The partial copies the residuals run, if any.
    pub copies: Vec<PartialCopy>,
}

/// An unknown of a nonlinear algebraic loop: the laws of the loop set each other, and the
/// equation that closes it has no closed-form root, so the state equations hold it as a
/// symbol with the equation `residual = 0` that sets it.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopUnknown {
    /// A name from the model's names: `e_b` for the effort of the 0-junction `b`.
    pub name: String,
    /// What it is, in words.
    pub description: String,
    /// The element whose equation closes the loop.
    pub element: String,
    /// Zero when the unknown has its value; over states, inputs, parameters and the loops'
    /// unknowns.
    pub residual: Expr,
}

/// A named combination of known signals that ARRs read with its derivatives: applying an
/// operator in d/dt of high degree to it, rather than to what it stands for multiplied out,
/// keeps an ARR between two stretches of unmeasured storage (a chain whose stages have
/// parameters of their own) the sum of their sizes, not their product.
#[derive(Clone, Debug, PartialEq)]
pub struct Auxiliary {
    /// `z1`, `z2`…, chosen apart from the model's names.
    pub name: String,
    /// Its time derivatives, each over parameters, inputs, measured signals and earlier
    /// auxiliary signals: `derivatives[n]` is the n-th, `derivatives[0]` the definition, up
    /// to the highest order read.
    pub derivatives: Vec<Expr>,
}

impl Auxiliary {
    /// What it is defined as.
    pub fn definition(&self) -> Expr {
        self.derivatives[0]
    }

    /// Its `n`-th time derivative, if an ARR reads that far.
    pub fn derivative(&self, n: u32) -> Option<Expr> {
        nth(&self.derivatives, n)
    }
}

impl Root {
    /// Its `n`-th time derivative (the 0-th is the root itself), if an ARR reads that far.
    pub fn derivative(&self, n: u32) -> Option<Expr> {
        nth(&self.derivatives, n)
    }
}

/// The `n`-th of a table of derivatives.
fn nth(derivatives: &[Expr], n: u32) -> Option<Expr> {
    usize::try_from(n)
        .ok()
        .and_then(|n| derivatives.get(n).copied())
}

/// A variable an ARR reads that a law sets and no closed form gives: the law read for its
/// input (`e = k1 q + k3 q^3` for `q`, given `e`). A residual generator finds it at each
/// sample as the root of [`Root::residual`] (Newton's method from the last sample's root,
/// with bisection when Newton does not converge); the ARR may read its derivatives, each
/// written in terms of it ([`Root::derivatives`]: `z' = −(∂g/∂t)/(∂g/∂z)`), or, realised by
/// integration, its value only.
#[derive(Clone, Debug, PartialEq)]
pub struct Root {
    /// The variable's name in the model's terms (`q_spring`, `e_valve`), apart from every
    /// other name.
    pub name: String,
    /// The element whose law sets it.
    pub element: String,
    /// `g`: zero at the root; over parameters, signals, earlier roots and this root.
    pub residual: Expr,
    /// `∂g/∂z`.
    pub slope: Expr,
    /// Its time derivatives as far as the ARRs read them, each over parameters, signals and
    /// the roots' values; `derivatives[0]` is the root itself.
    pub derivatives: Vec<Expr>,
}

/// What an ARR reads of one input or measured signal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignalUse {
    /// The signal.
    pub signal: Signal,
    /// The derivative orders read, increasing (0: the value itself).
    pub orders: Vec<u32>,
    /// Whether its integral from the start of the record is read.
    pub integral: bool,
}

/// A known signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Signal {
    /// An input.
    Input(Handle<Input>),
    /// A measured signal.
    Sensor(Handle<Sensor>),
}

/// An analytical redundancy relation: `expr = 0` while the machine is healthy.
#[derive(Clone, Debug, PartialEq)]
pub struct Arr {
    /// `ARR1`, `ARR2`…
    pub name: String,
    /// The junction it is written at.
    pub junction: String,
    /// The detector it is attributed to.
    pub sensor: Option<Handle<Sensor>>,
    /// The residual, over parameters, inputs and measured signals (with derivatives and
    /// integrals); a simulated one over one measured signal and states too.
    pub expr: Expr,
    /// Whether it is a relation of measured signals or a detector against a copy of the model.
    pub form: ResidualForm,
    /// The FSM rows it is sensitive to.
    pub components: Vec<Handle<Component>>,
    /// The components whose equations were left out to derive it: their faults cannot reach
    /// it (empty for one detector's ARR of the whole model).
    pub without: Vec<Handle<Component>>,
    /// The signals it reads, in input then sensor order.
    pub reads: Vec<SignalUse>,
    /// The arguments of the `int(..)` it holds that are not one signal's integral.
    pub integrals: Vec<Expr>,
    /// The auxiliary signals it reads, directly or through others, in definition order:
    /// part of the relation, to be written with it.
    pub auxiliaries: Vec<Handle<Auxiliary>>,
    /// The roots it reads, directly or through others' laws, in definition order: part of
    /// the relation, to be written with it.
    pub roots: Vec<Handle<Root>>,
    /// `∂r/∂θ` for each uncertain parameter θ it depends on, over the same signals: the
    /// adaptive threshold is `Σ |∂r/∂θ| Δθ`. `None` when they could not be derived (an ARR
    /// that reads auxiliary signals, or one realised by integration): such an ARR has no
    /// adaptive threshold.
    pub sensitivities: Option<Vec<(Handle<Parameter>, Expr)>>,
    /// How a residual generator evaluates it.
    pub realisation: Realisation,
    /// The laws its derivation read the other way, with where their inverses hold: where
    /// the record leaves that domain, the residual no longer says the law holds.
    pub inverted: Vec<InvertedLaw>,
}

impl Arr {
    /// The expression a residual generator evaluates: the relation itself, or, realised by
    /// integration, `level + int(rate)` (before the value at the reference is subtracted).
    pub fn evaluated(&self) -> Expr {
        match &self.realisation {
            Realisation::Direct => self.expr,
            Realisation::Integrated(i) => i.expr,
        }
    }

    /// What [`Arr::evaluated`] reads: the signals, and the arguments of `int(..)` that are
    /// not one signal's integral.
    pub fn evaluated_reads(&self) -> (&[SignalUse], &[Expr]) {
        match &self.realisation {
            Realisation::Direct => (&self.reads, &self.integrals),
            Realisation::Integrated(i) => (&i.reads, &i.integrals),
        }
    }

    /// The highest derivative order of a signal that its realisation reads.
    pub fn realised_order(&self) -> u32 {
        let (reads, _) = self.evaluated_reads();
        reads
            .iter()
            .filter_map(|r| r.orders.last().copied())
            .max()
            .unwrap_or(0)
    }
}

/// How a residual is evaluated from sampled signals.
#[derive(Clone, Debug, PartialEq)]
pub enum Realisation {
    /// As written: every derivative it reads is estimated from the samples.
    Direct,
    /// By integration: the relation is `r = rate + d(level)/dt`, where `rate` reads no
    /// derivative and `level` reads each derivative one order lower, so the residual is
    /// `∫ r dt` from a reference instant, `level(t) − level(t₀) + ∫_{t₀}^t rate dt`: the
    /// same zero set, with one order of differentiation fewer taken from noisy samples.
    Integrated(Integrated),
}

/// An ARR realised by integration (see [`Realisation::Integrated`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Integrated {
    /// `F`: what the relation is the time derivative of, less the rate's integral.
    pub level: Expr,
    /// `A`: the part of the relation that reads no derivative.
    pub rate: Expr,
    /// `level + int(rate)`: what is evaluated before the reference is subtracted.
    pub expr: Expr,
    /// What [`Integrated::expr`] reads.
    pub reads: Vec<SignalUse>,
    /// The arguments of the `int(..)` it holds that are not one signal's integral.
    pub integrals: Vec<Expr>,
}

/// How a residual is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResidualForm {
    /// An analytical redundancy relation: parameters, inputs and measured signals with their
    /// derivatives and integrals, evaluated sample by sample.
    Relation,
    /// A detector's reading less the output of a copy of the model: [`Arr::expr`] reads
    /// states ([`Symbol::State`]) of that copy, integrated with [`Compiled::state_space`]'s
    /// equations and the inputs as commanded, from the model's initial state (at rest). It
    /// reads no other detector, even where the model's modulations do (the copy reads the
    /// outputs they measure); it holds while the copy starts where the plant does and its
    /// unmeasured motion settles.
    Simulated,
}

/// What kind of component an FSM row is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ComponentKind {
    /// An element, by its kind's name (`R`, `MSe`…); a source is an actuator.
    Element(&'static str),
    /// A detector (a sensor).
    Sensor(SensorKind),
    /// A `let` with parameters of its own that modulates elements (the bench's backlash `w`).
    Modulation,
}

impl ComponentKind {
    /// The kind as printed: `R`, `MSe`, `Df`, `let`.
    pub fn name(self) -> &'static str {
        match self {
            ComponentKind::Element(k) => k,
            ComponentKind::Sensor(k) => k.name(),
            ComponentKind::Modulation => "let",
        }
    }
}

/// One row of the fault signature matrix: a component that can fail.
#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    /// Its name.
    pub name: String,
    /// What it is.
    pub kind: ComponentKind,
    /// The parameters that belong to it.
    pub parameters: Vec<Handle<Parameter>>,
    /// The signals it applies or measures.
    pub signals: Vec<String>,
    /// The ARRs (by position in [`Compiled::arrs`]) it shows in, increasing.
    pub marks: Vec<usize>,
    /// `Db`: some residual is sensitive to it.
    pub detectable: bool,
    /// `Ib`: detectable with a signature no other component has.
    pub isolable: bool,
}

impl Component {
    /// Its signature over `n` residuals.
    pub fn signature(&self, n: usize) -> Vec<bool> {
        let mut s = vec![false; n];
        for &m in &self.marks {
            if let Some(bit) = s.get_mut(m) {
                *bit = true;
            }
        }
        s
    }
}

/// Single faults grouped by what tells them apart: the fault classes. A fault is isolable
/// from another when it is detectable and in another class; the isolability matrix is
/// therefore block-diagonal, one block per class (see [`FaultClasses::isolable`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FaultClasses {
    /// The detectable components, in classes that nothing tells apart: each class in row
    /// order, the classes by their first member.
    pub classes: Vec<Vec<Handle<Component>>>,
    /// The components no residual shows.
    pub undetectable: Vec<Handle<Component>>,
}

impl FaultClasses {
    /// The class of a component, by position in [`FaultClasses::classes`]; `None` if it is
    /// undetectable. It searches the classes: for every component, use
    /// [`FaultClasses::by_component`].
    pub fn class_of(&self, c: Handle<Component>) -> Option<usize> {
        self.classes.iter().position(|k| k.contains(&c))
    }

    /// The class of each of `components` components, by handle index: what a table of every
    /// row reads, in time linear in the model (one search per row was quadratic: a quarter of
    /// the LaTeX of a 25,000-stage chain).
    pub fn by_component(&self, components: usize) -> Vec<Option<usize>> {
        let mut of = vec![None; components];
        for (k, class) in self.classes.iter().enumerate() {
            for c in class {
                if let Some(slot) = of.get_mut(c.index()) {
                    *slot = Some(k);
                }
            }
        }
        of
    }

    /// Whether a fault of `a` can be told from one of `b`: `a` is detectable and its class
    /// is not `b`'s. An undetectable fault is told from nothing.
    pub fn isolable(&self, a: Handle<Component>, b: Handle<Component>) -> bool {
        match (self.class_of(a), self.class_of(b)) {
            (Some(x), Some(y)) => x != y,
            (Some(_), None) => true,
            (None, _) => false,
        }
    }
}

/// What the residuals can tell apart.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Isolability {
    /// Which residuals [`Compiled::arrs`] holds.
    pub residuals: crate::fdi::ResidualSet,
    /// With the ARRs in [`Compiled::arrs`] (their signatures).
    pub selected: FaultClasses,
    /// With every candidate residual bgc could write (`None` when only one ARR per detector
    /// was derived).
    pub candidates: Option<FaultClasses>,
    /// With every residual the equations allow, once the dependences bgc proved cancel are
    /// taken out of the structural classes (`None` with only one ARR per detector): the
    /// classes of [`Isolability::possible`], merged where every residual without one class
    /// cancels another's terms.
    pub bound: Option<FaultClasses>,
    /// With every residual the model's equations allow, by a structural analysis: the most
    /// any set of residuals from these detectors can reach.
    pub possible: FaultClasses,
    /// Whether the model has too many fault classes for a derivation of the whole model per
    /// class: its candidates come from the part of the model around each class, and what
    /// the structure allows beyond them is not analysed.
    pub capped: bool,
    /// The residuals the structure allows that bgc could not write, by the components they
    /// would be derived without.
    pub unrealised: Vec<Unrealised>,
}

/// Residuals of the model without some components that the structure allows and bgc could
/// not write: what they would show, and what the derivation met.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unrealised {
    /// The components left out.
    pub without: Vec<Handle<Component>>,
    /// The components such a residual would show that no written one without them does.
    pub unseen: Vec<Handle<Component>>,
    /// Those of `unseen` that a residual derived without them reads, and whose terms cancel
    /// in it: the structure counts a dependence that is not there.
    pub cancelled: Vec<Handle<Component>>,
    /// Whether bgc wrote as many residuals without these components as the equations allow:
    /// then none can show `unseen`.
    pub complete: bool,
    /// What the derivation met, in the model's names.
    pub reasons: Vec<String>,
}

/// Which causality a report is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Preferred integral causality: for the state equations.
    Simulation,
    /// Preferred derivative causality, detectors inverted: for the ARRs.
    Diagnosis,
}

/// The causality a storage element took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageCausality {
    /// It holds a state.
    Integral,
    /// Its output is a derivative.
    Derivative,
    /// Its equation was not used.
    Unassigned,
}

/// What sets a junction's common variable.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Setter {
    /// The power bond of this number (the strong bond).
    Bond(u32),
    /// An inverted detector.
    Detector(String),
    /// Nothing: the variable could not be computed.
    Nothing,
}

/// The causality of one mode, in the model's names.
#[derive(Clone, Debug, PartialEq)]
pub struct CausalityReport {
    /// The mode.
    pub mode: Mode,
    /// Each storage element's name and causality.
    pub storage: Vec<(String, StorageCausality)>,
    /// Each junction's name and what sets it.
    pub junctions: Vec<(String, Setter)>,
    /// The messages of this mode's errors, each once.
    pub problems: Vec<String>,
    /// The messages of this mode's warnings, each once: what its results assume.
    pub notes: Vec<String>,
    /// The laws this causality reads the other way, through their closed-form inverses.
    pub inverted: Vec<InvertedLaw>,
}

/// A law read the other way, as the output states it.
#[derive(Clone, Debug, PartialEq)]
pub struct InvertedLaw {
    /// The element's name.
    pub element: String,
    /// The inverse as an equation in the element's port variables: `e = (f/c)^2`.
    pub law: String,
    /// The conditions under which it is the law's solution (`f/c >= 0`); empty when always.
    pub domain: Vec<String>,
}

/// A parameter that several components of the fault signature matrix read.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedParameter {
    /// The parameter.
    pub parameter: Handle<Parameter>,
    /// The components whose rows name it, in row order.
    pub components: Vec<Handle<Component>>,
    /// The ARRs (by index) a change of it can show in: the union of those rows' signatures.
    pub marks: Vec<usize>,
}

/// What a node of the drawing is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeClass {
    /// A junction, `0` or `1`.
    Junction(&'static str),
    /// An element, by its kind's name.
    Element(&'static str),
    /// A detector.
    Sensor(SensorKind),
}

/// A node of the bond graph, for drawings and summaries.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphNode {
    /// Its name.
    pub name: String,
    /// What it is.
    pub class: NodeClass,
    /// Its law as written (elements), or its description (detectors).
    pub note: String,
    /// The signals a modulated element's law reads (inputs, detectors, `let`s, `t`), each
    /// once in the order written; empty for other nodes.
    pub modulation: Vec<String>,
}

/// Where a bond's causal stroke is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stroke {
    /// No causality known (or a signal bond).
    None,
    /// At the head: the tail sets the effort.
    Head,
    /// At the tail: the head sets the effort.
    Tail,
}

/// A bond, directed along positive power.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphBond {
    /// Its number.
    pub number: u32,
    /// Where power comes from.
    pub tail: Handle<GraphNode>,
    /// Where power goes.
    pub head: Handle<GraphNode>,
    /// A signal bond to a detector (no power).
    pub signal: bool,
    /// Its causal stroke in simulation causality.
    pub stroke: Stroke,
}

/// The bond graph itself, as drawings and summaries need it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Graph {
    /// Nodes, in declaration order.
    pub nodes: Arena<GraphNode>,
    /// Bonds, in number order.
    pub bonds: Vec<GraphBond>,
}

/// Everything bgc derived from a model that is right; what is not is in the diagnostics.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// The model's name.
    pub name: String,
    /// The name of the file (or stream) it came from.
    pub file_name: String,
    /// Parameters, in declaration order.
    pub parameters: Arena<Parameter>,
    /// Inputs, in declaration order.
    pub inputs: Arena<Input>,
    /// Detectors, in declaration order.
    pub sensors: Arena<Sensor>,
    /// States, in declaration order of their storage elements.
    pub states: Arena<State>,
    /// The expressions of the state equations, outputs and ARRs.
    pub exprs: Exprs,
    /// The state equations, when they were asked for and could be derived.
    pub state_space: Option<StateSpace>,
    /// The ARRs that could be derived (when they were asked for).
    pub arrs: Vec<Arr>,
    /// The auxiliary signals the ARRs read, each defined before it is used.
    pub auxiliaries: Arena<Auxiliary>,
    /// The variables the ARRs read that are set numerically, each after those its law reads.
    pub roots: Arena<Root>,
    /// Whether ARRs were derived at all (`false` when only the state equations were asked for).
    pub diagnosed: bool,
    /// Whether a law or a `let` reads time `t` (a sensor's drift aside): a record's clock
    /// then matters, not only its steps.
    pub reads_time: bool,
    /// The rows of the fault signature matrix.
    pub components: Arena<Component>,
    /// The fault classes, with the ARRs and with every residual possible.
    pub isolability: Isolability,
    /// The causality reports of the modes that were run.
    pub causality: Vec<CausalityReport>,
    /// The bond graph.
    pub graph: Graph,
    /// Every diagnostic, from the parser to the product.
    pub diagnostics: Diagnostics,
    /// How many of the errors concern only the state equations (a storage law they cannot
    /// use, a conflict, a loop): the ARRs and their residual code do not depend on those.
    state_errors: usize,
    lines: LineIndex,
    source: String,
}

/// The derivatives of auxiliary signals (signal, order) that `roots` read, directly or
/// through the derivatives of others.
pub(crate) fn auxiliary_derivatives_read(
    exprs: &Exprs,
    auxiliaries: &Arena<Auxiliary>,
    roots: &[Expr],
) -> std::collections::BTreeSet<(Handle<Auxiliary>, u32)> {
    let mut out = std::collections::BTreeSet::new();
    let mut stack: Vec<Expr> = roots.to_vec();
    while let Some(e) = stack.pop() {
        for leaf in exprs.leaves(e) {
            if let Symbol::Auxiliary(a, n) = leaf {
                if out.insert((a, n)) {
                    stack.extend(auxiliaries[a].derivative(n));
                }
            }
        }
    }
    out
}

/// The roots that `from` reads, directly, through auxiliary signals or through the laws of
/// other roots, in definition order.
pub(crate) fn roots_read(
    exprs: &Exprs,
    auxiliaries: &Arena<Auxiliary>,
    roots: &Arena<Root>,
    from: &[Expr],
) -> Vec<Handle<Root>> {
    let read = auxiliary_derivatives_read(exprs, auxiliaries, from);
    let mut stack: Vec<Expr> = (from.iter().copied())
        .chain(
            read.into_iter()
                .filter_map(|(a, n)| auxiliaries[a].derivative(n)),
        )
        .collect();
    let mut out = std::collections::BTreeSet::new();
    while let Some(e) = stack.pop() {
        for leaf in exprs.leaves(e) {
            if let Symbol::Root(h, n) = leaf {
                if out.insert(h) {
                    stack.push(roots[h].residual);
                }
                stack.extend(roots[h].derivative(n).filter(|_| n > 0));
            }
        }
    }
    out.into_iter().collect()
}

impl Compiled {
    /// How many of [`Compiled::states`] are the model's own (the partial copies' come after
    /// them): the simulation's state vector.
    pub fn model_states(&self) -> usize {
        self.states.values().filter(|s| s.copy.is_none()).count()
    }

    /// The same model with its relations alone, where it carries simulated residuals beside
    /// them (the bank): what a fit of its parameters and a fault's size read, at the cost of
    /// the relations (a copy runs the model at every evaluation). Each component's marks are
    /// those of the relations kept; the isolability stays the whole set's. `None` where
    /// there is no simulated residual to leave out, or nothing else.
    pub fn relations(&self) -> Option<Compiled> {
        let kept: Vec<usize> = (0..self.arrs.len())
            .filter(|&k| self.arrs[k].form == ResidualForm::Relation)
            .collect();
        if kept.is_empty() || kept.len() == self.arrs.len() {
            return None;
        }
        let mut out = self.clone();
        out.arrs = kept.iter().map(|&k| self.arrs[k].clone()).collect();
        let handles: Vec<Handle<Component>> = out.components.iter().map(|(h, _)| h).collect();
        for h in handles {
            let component = out.components.get_mut(h);
            component.marks = (component.marks.iter())
                .filter_map(|m| kept.iter().position(|k| k == m))
                .collect();
        }
        Some(out)
    }
}

impl Compiled {
    /// The roots that `from` reads, directly or through auxiliary signals and other roots'
    /// laws: what code evaluating `from` must solve first, in that order.
    pub fn roots_read(&self, from: &[Expr]) -> Vec<Handle<Root>> {
        roots_read(&self.exprs, &self.auxiliaries, &self.roots, from)
    }

    /// The derivatives of auxiliary signals (signal, order) that `roots` read, directly or
    /// through the derivatives of others: what code evaluating `roots` must compute first.
    pub fn auxiliary_derivatives_read(
        &self,
        roots: &[Expr],
    ) -> std::collections::BTreeSet<(Handle<Auxiliary>, u32)> {
        auxiliary_derivatives_read(&self.exprs, &self.auxiliaries, roots)
    }

    /// The line and column of a span's start.
    pub fn line_col(&self, span: Span) -> LineCol {
        self.lines.line_col(&self.source, span.start)
    }

    /// Whether residual code must be refused: an error other than the state equations',
    /// no ARR, or a simulated residual whose copy of the model needs the state equations that
    /// were refused.
    pub fn residual_code_refused(&self) -> bool {
        let others = self.diagnostics.error_count() > self.state_errors;
        let copy_missing = self.state_space.is_none()
            && self.arrs.iter().any(|a| a.form == ResidualForm::Simulated);
        others || self.arrs.is_empty() || copy_missing
    }

    /// The parameters that several rows of the fault signature matrix read, each with those
    /// rows and the ARRs a change of it can show in: the union of their signatures. (A row
    /// faults its component alone; a real change of a shared parameter faults them all, and
    /// its effects may cancel in an ARR, so the union is where it can show, not where it
    /// must.)
    pub fn shared_parameters(&self) -> Vec<SharedParameter> {
        self.parameters
            .iter()
            .filter_map(|(parameter, _)| {
                let components: Vec<Handle<Component>> = self
                    .components
                    .iter()
                    .filter(|(_, k)| k.parameters.contains(&parameter))
                    .map(|(h, _)| h)
                    .collect();
                if components.len() < 2 {
                    return None;
                }
                // Their rows, and every ARR that reads it: a relation may read it through
                // another component's law (the gear's ratio in the twist a dead zone reads).
                let reading = (0..self.arrs.len()).filter(|&k| self.arr_reads(k, parameter));
                let mut marks: Vec<usize> = components
                    .iter()
                    .flat_map(|&h| self.components[h].marks.iter().copied())
                    .chain(reading)
                    .collect();
                marks.sort_unstable();
                marks.dedup();
                Some(SharedParameter {
                    parameter,
                    components,
                    marks,
                })
            })
            .collect()
    }

    /// Whether ARR `k` reads `p`, in its relation, its auxiliary signals or its roots' laws.
    fn arr_reads(&self, k: usize, p: Handle<Parameter>) -> bool {
        let arr = &self.arrs[k];
        let mut exprs = vec![arr.expr];
        exprs.extend(
            arr.auxiliaries
                .iter()
                .flat_map(|&a| self.auxiliaries[a].derivatives.iter().copied()),
        );
        exprs.extend(arr.roots.iter().map(|&r| self.roots[r].residual));
        exprs
            .iter()
            .any(|&e| self.exprs.leaves(e).contains(&Symbol::Parameter(p)))
    }

    /// Whether any diagnostic is an error: some output was refused.
    pub fn has_errors(&self) -> bool {
        self.diagnostics.has_errors()
    }
}
