//! The equations of a bond graph, as relations between bond variables that can be solved in
//! chosen directions: what causality assignment orients.

use crate::index::Idx;
use std::collections::{BTreeSet, HashMap};

use petgraph::Direction::{Incoming, Outgoing};

use super::carried;
use super::mode::Mode;
use crate::expr::{BinOp, Expr};
use crate::graph::{
    BondGraph, BondId, BondKind, DetectorKind, ElementKind, JunctionKind, Law, LetId, NodeId,
    NodeKind, PortVar, Signal, SignalExpr,
};
// An unknown's index into [`System::vars`].
pub(crate) use crate::symbolic::VarId;
use crate::symbolic::{
    invert, known_signal_rule, Condition, Derivatives, ExprId, Leaf, Node, Pool, StateIx,
};

/// What an unknown is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Var {
    /// The effort on a bond.
    Effort(BondId),
    /// The flow on a bond.
    Flow(BondId),
    /// The common variable of a junction (effort of a 0, flow of a 1).
    Common(NodeId),
    /// The value of a `let` held as an unknown: a modulation whose fault is being left out,
    /// eliminated between the sources it scales.
    Let(LetId),
}

impl Var {
    /// The unknown as a reader of the model names it: "the flow of bond 3 (`res -> a`)".
    pub(crate) fn describe(self, model: &BondGraph) -> String {
        let bond = |b: BondId| {
            let (tail, head) = model.ends(b);
            format!(
                "bond {} (`{} -> {}`)",
                model.bond(b).number,
                model.node(tail).name,
                model.node(head).name
            )
        };
        match self {
            Var::Effort(b) => format!("the effort of {}", bond(b)),
            Var::Flow(b) => format!("the flow of {}", bond(b)),
            Var::Common(j) => {
                let node = model.node(j);
                let what = match node.junction_kind() {
                    Some(JunctionKind::Zero) => "effort",
                    _ => "flow",
                };
                format!("the common {what} of junction `{}`", node.name)
            }
            Var::Let(l) => format!("the value of `{}`", model.lets[l.index()].name),
        }
    }

    /// A short name from the model's names: `e_J` or `f_J` for a junction's common
    /// variable, `e_TAIL_HEAD` or `f_TAIL_HEAD` for a bond's.
    pub(crate) fn short_name(self, model: &BondGraph) -> String {
        let ends = |b: BondId| {
            let (tail, head) = model.ends(b);
            format!("{}_{}", model.node(tail).name, model.node(head).name)
        };
        match self {
            Var::Effort(b) => format!("e_{}", ends(b)),
            Var::Flow(b) => format!("f_{}", ends(b)),
            Var::Common(j) => {
                let node = model.node(j);
                match node.junction_kind() {
                    Some(JunctionKind::Zero) => format!("e_{}", node.name),
                    _ => format!("f_{}", node.name),
                }
            }
            Var::Let(l) => model.lets[l.index()].name.clone(),
        }
    }

    /// The nodes this unknown belongs to, for pointing at the model's text.
    pub(crate) fn nodes(self, model: &BondGraph) -> Vec<NodeId> {
        match self {
            Var::Effort(b) | Var::Flow(b) => {
                let (tail, head) = model.ends(b);
                vec![tail, head]
            }
            Var::Common(j) => vec![j],
            Var::Let(_) => Vec::new(),
        }
    }
}

/// How an equation relates its unknowns.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Relation {
    /// `var = value`, `value` over knowns (a source; an inverted detector; a state output).
    Assign {
        /// The unknown defined.
        var: VarId,
        /// Its value.
        value: ExprId,
    },
    /// `a = k·b`, solvable for either side.
    Scale {
        /// Left side.
        a: VarId,
        /// Right side.
        b: VarId,
        /// The factor, over knowns.
        k: ExprId,
    },
    /// `out = rhs`, `rhs` over a `Var` leaf: solvable for `out`, and for that leaf's unknown
    /// when the law has a closed-form inverse (a nonlinear law).
    Law {
        /// The unknown defined.
        out: VarId,
        /// Its definition.
        rhs: ExprId,
        /// The input's unknown and its value over `out`'s leaf, when the law can be inverted.
        inverse: Option<(VarId, ExprId)>,
    },
    /// `Σ ± var = 0` (a junction's balance), solvable for any term.
    Sum {
        /// The terms, `true` for plus.
        terms: Vec<(bool, VarId)>,
    },
    /// A storage element in diagnosis: `out = d/dt g(input)` (derivative causality) and/or
    /// `out2 = h(int(input2))` (integral causality), each over the `Var` leaf of its input.
    Storage {
        /// Derivative form: the rate, and g over the co-energy variable.
        derivative: Option<(VarId, ExprId)>,
        /// Integral form: the co-energy variable, and h over the integral of the rate.
        integral: Option<(VarId, ExprId)>,
        /// Derivative form through a root, in diagnosis, for a law `co = φ(x)` with no
        /// closed-form inverse: the rate, and φ over [`ARGUMENT`]. The energy variable `x`
        /// is then the root of `φ(x) − co`, found numerically at run time, and the rate is
        /// its derivative.
        implicit: Option<(VarId, ExprId)>,
    },
}

/// One equation and whose it is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Equation {
    /// The element, junction or detector whose law this is.
    pub owner: NodeId,
    /// The relation.
    pub relation: Relation,
    /// Every unknown it involves.
    pub vars: Vec<VarId>,
    /// The `let`s its expressions use, directly or through other `let`s.
    pub lets: Vec<LetId>,
}

/// A state variable of the integral-causality model.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct State {
    /// `p_NAME` for an `I`, `q_NAME` for a `C`; `f_NAME` or `e_NAME` for a co-energy state.
    pub name: String,
    /// The storage element.
    pub element: NodeId,
    /// The unknown whose value, times [`State::scale`], is the state's derivative (effort of
    /// an `I`, flow of a `C`).
    pub rate: VarId,
    /// `1/Φ'(x)` over the state's leaf, for a co-energy state `x` of a law `q = Φ(e)` or
    /// `p = Φ(f)` that has no closed-form inverse; `None` for an energy state.
    pub scale: Option<ExprId>,
}

/// A law read the other way: its closed-form inverse, and where that holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Inversion {
    /// The element whose law it is.
    pub element: NodeId,
    /// The variable the law gives, now the inverse's argument.
    pub given: PortVar,
    /// The variable the inverse gives.
    pub solved: PortVar,
    /// Its value, over [`ARGUMENT`].
    pub value: ExprId,
    /// Where `value` is the solution, over [`ARGUMENT`].
    pub domain: Vec<Condition>,
    /// The unknowns whose computation reads the inverse: the inversion is used when the
    /// element's equation solves one of them.
    pub needed_for: Vec<VarId>,
}

/// The leaf standing for an inverse's argument in [`Inversion::value`].
pub(crate) const ARGUMENT: Leaf = Leaf::Tear(VarId(u32::MAX), 1);
/// The leaf standing for a law's input while it is inverted.
const INPUT: Leaf = Leaf::Tear(VarId(u32::MAX), 0);

/// A storage element that cannot take the causality its mode requires, and why.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Refusal {
    /// The element.
    pub element: NodeId,
    /// Why.
    pub reason: String,
}

/// The equations of a model for one mode, over one expression pool.
#[derive(Clone, Debug)]
pub(crate) struct System {
    /// The unknowns.
    pub vars: Vec<Var>,
    /// The equations.
    pub equations: Vec<Equation>,
    /// State variables (integral mode).
    pub states: Vec<State>,
    /// Storage elements whose law cannot be used in the mode's causality.
    pub refusals: Vec<Refusal>,
    /// The laws that can be read the other way, with their domains.
    pub inversions: Vec<Inversion>,
    /// The expressions.
    pub pool: Pool,
    index: HashMap<Var, VarId>,
}

impl System {
    /// The id of an unknown.
    pub(crate) fn var(&self, var: Var) -> Option<VarId> {
        self.index.get(&var).copied()
    }
}

/// Writes the equations of `model` for `mode`.
pub(crate) fn build(model: &BondGraph, mode: Mode) -> System {
    build_freeing(model, mode, &[])
}

/// Writes the equations of `model` for `mode`, with the `let`s of `free` held as unknowns in
/// the sources that scale them (`MSe W = N*w`): one source then gives the value, and the
/// others check it. Other laws that use them keep their expressions.
pub(crate) fn build_freeing(model: &BondGraph, mode: Mode, free: &[LetId]) -> System {
    build_in(model, mode, free, None)
}

/// [`build_freeing`] for the nodes of `scope` only (in increasing order), when given: the
/// equations of a part of the model, in time proportional to that part (and the `let`s).
pub(crate) fn build_in(
    model: &BondGraph,
    mode: Mode,
    free: &[LetId],
    scope: Option<&[NodeId]>,
) -> System {
    let mut b = Builder::new(model, mode, free);
    b.lets();
    let (bonds, nodes): (Vec<BondId>, Vec<NodeId>) = match scope {
        None => (model.bonds().collect(), model.nodes().collect()),
        Some(nodes) => {
            let mut bonds: Vec<BondId> = nodes
                .iter()
                .flat_map(|&n| {
                    let mut at = model.bonds_at(n, Incoming);
                    at.extend(model.bonds_at(n, Outgoing));
                    at
                })
                .collect();
            bonds.sort();
            bonds.dedup();
            (bonds, nodes.to_vec())
        }
    };
    for bond in bonds {
        if model.bond(bond).kind == BondKind::Power {
            b.new_var(Var::Effort(bond));
            b.new_var(Var::Flow(bond));
        }
    }
    for node in nodes {
        match &model.node(node).kind {
            NodeKind::Junction(kind) => b.junction(node, *kind),
            NodeKind::Element(kind, law) => b.element(node, *kind, law),
            NodeKind::Detector(kind) => b.detector(node, *kind),
        }
    }
    b.sys
}

/// The factor of a source's value over a free `let`.
enum Scale<'e> {
    /// `k * w` or `w * k`.
    By(&'e SignalExpr),
    /// `w / k`.
    Over(&'e SignalExpr),
    /// `w` or `-w`.
    Unit(f64),
}

/// `value` as a factor times one `let` of `free`, the factor free of it; `None` when it is
/// not of that form.
fn scaled_let<'e>(value: &'e SignalExpr, free: &[LetId]) -> Option<(LetId, Scale<'e>)> {
    let free_let = |e: &SignalExpr| match e {
        Expr::Leaf(Signal::Let(l)) if free.contains(l) => Some(*l),
        _ => None,
    };
    let (l, k) = match value {
        Expr::Neg(a) => (free_let(a)?, Scale::Unit(-1.0)),
        Expr::Binary(BinOp::Mul, a, b) => match (free_let(a), free_let(b)) {
            (Some(l), None) => (l, Scale::By(b)),
            (None, Some(l)) => (l, Scale::By(a)),
            _ => return None,
        },
        Expr::Binary(BinOp::Div, a, b) => (free_let(a)?, Scale::Over(b)),
        e => (free_let(e)?, Scale::Unit(1.0)),
    };
    let mentions = match &k {
        Scale::By(k) | Scale::Over(k) => names_a_let(k),
        Scale::Unit(_) => false,
    };
    (!mentions).then_some((l, k))
}

/// Whether `e` names any `let` (the factor of a free one must not depend on it, even
/// through another).
fn names_a_let(e: &SignalExpr) -> bool {
    match e {
        Expr::Num(_) => false,
        Expr::Leaf(s) => matches!(s, Signal::Let(_)),
        Expr::Neg(a) | Expr::Der(a, _) | Expr::Int(a) => names_a_let(a),
        Expr::Binary(_, a, b) => names_a_let(a) || names_a_let(b),
        Expr::Call(_, args) => args.iter().any(names_a_let),
    }
}

struct Builder<'m> {
    model: &'m BondGraph,
    mode: Mode,
    /// `let`s held as unknowns where a source scales them.
    free: &'m [LetId],
    sys: System,
    /// Each `let` as an expression, with the `let`s it names itself.
    lets: Vec<Option<(ExprId, Vec<LetId>)>>,
    /// The first `der()` whose differentiation passed [`MOST_DERIVATIVE_NODES`]: the order
    /// asked for and the one reached.
    oversized: Option<(u32, u32)>,
}

/// Most expression nodes one `der(x, n)` may add while it is differentiated. Each order of a
/// product of functions is nearly twice the one before, and every later stage costs about
/// 80 µs per node of it (`der()` of eight functions: 33,000 nodes at order 12, 3 s in all; at
/// order 16 it took 64 CPU-seconds and 1.3 GB before being refused as too large to print).
/// The nodes are counted order by order as they are made, and the model is refused at this
/// bound before any other stage runs.
pub(crate) const MOST_DERIVATIVE_NODES: usize = 50_000;

/// Where a `der()` that passes [`MOST_DERIVATIVE_NODES`] is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Holder {
    /// In a `let`'s definition.
    Let(LetId),
    /// In an element's law.
    Element(NodeId),
}

/// A `der(x, n)` too costly to differentiate: where, the order asked for and the order at
/// which the bound was passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Oversized {
    /// The `let` or element whose expression holds it.
    pub holder: Holder,
    /// The `n` of `der(x, n)`.
    pub asked: u32,
    /// The order whose derivative passed the bound.
    pub reached: u32,
}

/// The first `der()` of the model (in the `let`s' order, then the elements') whose
/// differentiation passes [`MOST_DERIVATIVE_NODES`], found before any other work, at the
/// cost of the bound at most.
pub(crate) fn first_oversized_derivative(model: &BondGraph) -> Option<Oversized> {
    let mut b = Builder::new(model, Mode::Diagnosis, &[]);
    let found = |b: &Builder<'_>, holder| {
        b.oversized.map(|(asked, reached)| Oversized {
            holder,
            asked,
            reached,
        })
    };
    for &id in &model.let_order {
        b.lower_let(id);
        if let Some(o) = found(&b, Holder::Let(id)) {
            return Some(o);
        }
    }
    for node in model.nodes() {
        if let NodeKind::Element(_, law) = &model.node(node).kind {
            b.expr(law.expr(), &mut |_| None, &mut Vec::new());
            if let Some(o) = found(&b, Holder::Element(node)) {
                return Some(o);
            }
        }
    }
    None
}

impl<'m> Builder<'m> {
    /// A builder of `model`'s equations for `mode`, with nothing written yet.
    fn new(model: &'m BondGraph, mode: Mode, free: &'m [LetId]) -> Self {
        Builder {
            model,
            mode,
            free,
            sys: System {
                vars: Vec::new(),
                equations: Vec::new(),
                states: Vec::new(),
                refusals: Vec::new(),
                inversions: Vec::new(),
                pool: Pool::default(),
                index: HashMap::new(),
            },
            lets: vec![None; model.lets.len()],
            oversized: None,
        }
    }

    fn new_var(&mut self, var: Var) -> VarId {
        let id = VarId(self.sys.vars.len() as u32);
        self.sys.vars.push(var);
        self.sys.index.insert(var, id);
        id
    }

    fn var(&mut self, var: Var) -> VarId {
        match self.sys.index.get(&var) {
            Some(&id) => id,
            None => self.new_var(var),
        }
    }

    fn leaf(&mut self, v: VarId) -> ExprId {
        self.sys.pool.leaf(Leaf::Var(v))
    }

    fn lets(&mut self) {
        for &id in &self.model.let_order {
            self.lower_let(id);
        }
    }

    /// The `let` `id` as an expression; those it uses are lowered already.
    fn lower_let(&mut self, id: LetId) {
        let mut used = Vec::new();
        let e = self.expr(&self.model.lets[id.index()].value, &mut |_| None, &mut used);
        used.sort();
        used.dedup();
        self.lets[id.index()] = Some((e, used));
    }

    /// An expression over signals as a pool expression; `port` gives the leaf of a port
    /// variable; the `let`s it names are added to `used`.
    fn expr(
        &mut self,
        expr: &SignalExpr,
        port: &mut dyn FnMut(PortVar) -> Option<ExprId>,
        used: &mut Vec<LetId>,
    ) -> ExprId {
        let p = &mut self.sys.pool;
        match expr {
            Expr::Num(x) => p.num(*x),
            Expr::Leaf(s) => match *s {
                Signal::Param(id) => p.leaf(Leaf::Param(id)),
                Signal::Input(id) => p.leaf(Leaf::Input(id, 0)),
                Signal::Sensor(id) => p.leaf(Leaf::Sensor(id, 0)),
                Signal::Time => p.leaf(Leaf::Time),
                Signal::Port(v) => port(v).unwrap_or_else(|| p.num(f64::NAN)),
                Signal::Let(id) => match &self.lets[id.index()] {
                    Some((e, _)) => {
                        used.push(id);
                        *e
                    }
                    None => p.num(f64::NAN),
                },
            },
            Expr::Neg(a) => {
                let a = self.expr(a, port, used);
                self.sys.pool.neg(a)
            }
            Expr::Binary(op, a, b) => {
                let a = self.expr(a, port, used);
                let b = self.expr(b, port, used);
                self.sys.pool.binary(*op, a, b)
            }
            Expr::Call(f, args) => {
                let args: Vec<ExprId> = args.iter().map(|a| self.expr(a, port, used)).collect();
                self.sys.pool.call(*f, &args)
            }
            Expr::Der(a, n) => {
                let mut e = self.expr(a, port, used);
                let start = self.sys.pool.len();
                for order in 1..=*n {
                    let mut d = Derivatives::new(known_signal_rule);
                    e = d
                        .of(&mut self.sys.pool, e)
                        .unwrap_or_else(|| self.sys.pool.num(f64::NAN));
                    let pool = &self.sys.pool;
                    if pool.len() - start > MOST_DERIVATIVE_NODES {
                        self.oversized.get_or_insert((*n, order));
                        return self.sys.pool.num(f64::NAN);
                    }
                }
                e
            }
            Expr::Int(a) => {
                let a = self.expr(a, port, used);
                self.sys.pool.int(a)
            }
        }
    }

    /// `direct` with every `let` they use in turn, sorted. Each `let` keeps only the ones
    /// it names itself, so a chain of n `let`s costs n here, not n² stored.
    fn through(&self, direct: Vec<LetId>) -> Vec<LetId> {
        let mut seen = BTreeSet::new();
        let mut stack = direct;
        while let Some(l) = stack.pop() {
            if seen.insert(l) {
                if let Some((_, named)) = &self.lets[l.index()] {
                    stack.extend(named.iter().copied());
                }
            }
        }
        seen.into_iter().collect()
    }

    fn push(&mut self, owner: NodeId, relation: Relation, lets: Vec<LetId>) {
        let mut vars = Vec::new();
        let mut exprs = Vec::new();
        match &relation {
            Relation::Assign { var, value } => {
                vars.push(*var);
                exprs.push(*value);
            }
            Relation::Scale { a, b, k } => {
                vars.extend([*a, *b]);
                exprs.push(*k);
            }
            Relation::Law { out, rhs, .. } => {
                vars.push(*out);
                exprs.push(*rhs);
            }
            Relation::Sum { terms } => vars.extend(terms.iter().map(|t| t.1)),
            Relation::Storage {
                derivative,
                integral,
                implicit,
            } => {
                for (out, g) in derivative.iter().chain(integral).chain(implicit) {
                    vars.push(*out);
                    exprs.push(*g);
                }
            }
        }
        for e in exprs {
            for leaf in self.sys.pool.leaves(e) {
                if let Leaf::Var(v) = leaf {
                    vars.push(v);
                }
            }
        }
        vars.sort();
        vars.dedup();
        let lets = self.through(lets);
        self.sys.equations.push(Equation {
            owner,
            relation,
            vars,
            lets,
        });
    }

    fn power_bonds(&self, node: NodeId) -> (Vec<BondId>, Vec<BondId>) {
        let power = |bonds: Vec<BondId>| -> Vec<BondId> {
            bonds
                .into_iter()
                .filter(|&b| self.model.bond(b).kind == BondKind::Power)
                .collect()
        };
        (
            power(self.model.bonds_at(node, Incoming)),
            power(self.model.bonds_at(node, Outgoing)),
        )
    }

    fn junction(&mut self, node: NodeId, kind: JunctionKind) {
        let common = self.var(Var::Common(node));
        let (incoming, outgoing) = self.power_bonds(node);
        let side = |b| match kind {
            JunctionKind::Zero => Var::Flow(b),
            JunctionKind::One => Var::Effort(b),
        };
        let shared = |b| match kind {
            JunctionKind::Zero => Var::Effort(b),
            JunctionKind::One => Var::Flow(b),
        };
        let one = self.sys.pool.num(1.0);
        let mut terms = Vec::new();
        for (plus, &b) in incoming
            .iter()
            .map(|b| (true, b))
            .chain(outgoing.iter().map(|b| (false, b)))
        {
            let a = self.var(shared(b));
            self.push(
                node,
                Relation::Scale {
                    a,
                    b: common,
                    k: one,
                },
                Vec::new(),
            );
            terms.push((plus, self.var(side(b))));
        }
        self.push(node, Relation::Sum { terms }, Vec::new());
    }

    fn detector(&mut self, node: NodeId, kind: DetectorKind) {
        // Only inverted detectors are equations; in integral mode a detector is an output.
        if self.mode != Mode::Diagnosis {
            return;
        }
        let Some(junction) = self.model.detector_junction(node) else {
            return;
        };
        let var = self.var(Var::Common(junction));
        // A `Dq` or `Dp` measures the integral: the junction's variable is its derivative.
        let measured = self.sys.pool.leaf(Leaf::Sensor(node, kind.integrals()));
        let faults = &self.model.node(node).faults;
        let value = carried::from_reading(&mut self.sys.pool, faults, measured, kind.integrals());
        self.push(node, Relation::Assign { var, value }, Vec::new());
    }

    fn element(&mut self, node: NodeId, kind: ElementKind, law: &Law) {
        let (incoming, outgoing) = self.power_bonds(node);
        let mut used = Vec::new();
        match kind {
            ElementKind::Se | ElementKind::MSe | ElementKind::Sf | ElementKind::MSf => {
                let Some(&b) = outgoing.first() else { return };
                let var = if matches!(kind, ElementKind::Se | ElementKind::MSe) {
                    self.var(Var::Effort(b))
                } else {
                    self.var(Var::Flow(b))
                };
                let faults = &self.model.node(node).faults;
                if !faults.0.is_empty() {
                    let value = self.expr(law.expr(), &mut |_| None, &mut used);
                    let value = carried::applied(&mut self.sys.pool, faults, value);
                    self.push(node, Relation::Assign { var, value }, used);
                    return;
                }
                if let Some((l, k)) = scaled_let(law.expr(), self.free) {
                    let k = match k {
                        Scale::By(k) => self.expr(k, &mut |_| None, &mut used),
                        Scale::Over(k) => {
                            let k = self.expr(k, &mut |_| None, &mut used);
                            let one = self.sys.pool.num(1.0);
                            self.sys.pool.binary(BinOp::Div, one, k)
                        }
                        Scale::Unit(x) => self.sys.pool.num(x),
                    };
                    let w = self.var(Var::Let(l));
                    self.push(node, Relation::Scale { a: var, b: w, k }, used);
                    return;
                }
                let value = self.expr(law.expr(), &mut |_| None, &mut used);
                self.push(node, Relation::Assign { var, value }, used);
            }
            ElementKind::R | ElementKind::MR => {
                let Some(&b) = incoming.first() else { return };
                let (e, f) = (self.var(Var::Effort(b)), self.var(Var::Flow(b)));
                let relation = match law {
                    Law::Linear(x) => {
                        let k = self.expr(x, &mut |_| None, &mut used);
                        Relation::Scale { a: e, b: f, k }
                    }
                    Law::Explicit { output, rhs } => {
                        let (out, input, port) = if *output == PortVar::E {
                            (e, f, PortVar::F)
                        } else {
                            (f, e, PortVar::E)
                        };
                        let leaf = self.leaf(input);
                        let forward =
                            self.expr(rhs, &mut |v| (v == port).then_some(leaf), &mut used);
                        let inverse = self
                            .invert(node, rhs, *output, port, &[input], &mut used)
                            .map(|v| {
                                let out_leaf = self.leaf(out);
                                (input, self.argument(v, out_leaf))
                            });
                        Relation::Law {
                            out,
                            rhs: forward,
                            inverse,
                        }
                    }
                    _ => return,
                };
                self.push(node, relation, used);
            }
            ElementKind::TF | ElementKind::MTF | ElementKind::GY | ElementKind::MGY => {
                let (Some(&b1), Some(&b2)) = (incoming.first(), outgoing.first()) else {
                    return;
                };
                let m = self.expr(law.expr(), &mut |_| None, &mut used);
                let (e1, f1, e2, f2) = (
                    self.var(Var::Effort(b1)),
                    self.var(Var::Flow(b1)),
                    self.var(Var::Effort(b2)),
                    self.var(Var::Flow(b2)),
                );
                let (first, second) = if matches!(kind, ElementKind::TF | ElementKind::MTF) {
                    ((e1, e2), (f2, f1))
                } else {
                    ((e1, f2), (e2, f1))
                };
                self.push(
                    node,
                    Relation::Scale {
                        a: first.0,
                        b: first.1,
                        k: m,
                    },
                    used.clone(),
                );
                self.push(
                    node,
                    Relation::Scale {
                        a: second.0,
                        b: second.1,
                        k: m,
                    },
                    used,
                );
            }
            ElementKind::I | ElementKind::C | ElementKind::MI | ElementKind::MC => {
                self.storage(node, kind.base(), law, incoming.first().copied())
            }
        }
    }

    /// The closed-form inverse of `node`'s law `given = rhs(solved)`, over [`ARGUMENT`],
    /// recorded with its domain as needed to compute `needed_for`.
    fn invert(
        &mut self,
        node: NodeId,
        rhs: &SignalExpr,
        given: PortVar,
        solved: PortVar,
        needed_for: &[VarId],
        used: &mut Vec<LetId>,
    ) -> Option<ExprId> {
        // Elements are written one at a time: an element's inversion, if any, is the last.
        let last = self.sys.inversions.last_mut();
        if let Some(known) = last.filter(|i| i.element == node) {
            known.needed_for.extend_from_slice(needed_for);
            return Some(known.value);
        }
        let input = self.sys.pool.leaf(INPUT);
        let forward = self.expr(rhs, &mut |v| (v == solved).then_some(input), used);
        let argument = self.sys.pool.leaf(ARGUMENT);
        let inverse = invert(&mut self.sys.pool, forward, INPUT, argument)?;
        self.sys.inversions.push(Inversion {
            element: node,
            given,
            solved,
            value: inverse.value,
            domain: inverse.domain,
            needed_for: needed_for.to_vec(),
        });
        Some(inverse.value)
    }

    /// An inverse's value at `y`.
    fn argument(&mut self, value: ExprId, y: ExprId) -> ExprId {
        self.sys
            .pool
            .substitute(value, &mut |_, l| (l == ARGUMENT).then_some(y))
    }

    /// `I`: f = φ(p), dp/dt = e. `C`: e = φ(q), dq/dt = f. A law given the other way
    /// (`q = Φ(e)`) serves through its closed-form inverse, or, where it has none, through a
    /// co-energy state in integral causality.
    fn storage(&mut self, node: NodeId, kind: ElementKind, law: &Law, bond: Option<BondId>) {
        let Some(b) = bond else { return };
        let (e, f) = (self.var(Var::Effort(b)), self.var(Var::Flow(b)));
        // (output of the energy law, rate = derivative of the energy variable, energy variable)
        let (co, rate, energy) = if kind == ElementKind::I {
            (f, e, PortVar::P)
        } else {
            (e, f, PortVar::Q)
        };
        let co_port = if kind == ElementKind::I {
            PortVar::F
        } else {
            PortVar::E
        };
        let name = format!("{}_{}", energy.name(), self.model.node(node).name);
        let mut used = Vec::new();
        // φ(x) as a function of a given expression for the energy variable, if the law gives it.
        let phi = |this: &mut Self, x: ExprId, used: &mut Vec<LetId>| -> Option<ExprId> {
            match law {
                Law::Linear(k) => {
                    let k = this.expr(k, &mut |_| None, used);
                    Some(this.sys.pool.mul(k, x))
                }
                Law::Explicit { output, rhs } if *output == co_port => {
                    Some(this.expr(rhs, &mut |v| (v == energy).then_some(x), used))
                }
                Law::Explicit { rhs, .. } => {
                    let v = this.invert(node, rhs, energy, co_port, &[co], used)?;
                    Some(this.argument(v, x))
                }
                _ => None,
            }
        };
        // The energy variable as a function of the co-energy one, if the law gives it.
        let inverse = |this: &mut Self, y: ExprId, used: &mut Vec<LetId>| -> Option<ExprId> {
            match law {
                Law::Linear(k) => {
                    let k = this.expr(k, &mut |_| None, used);
                    Some(this.sys.pool.div(y, k))
                }
                Law::Explicit { output, rhs } if *output == energy => {
                    Some(this.expr(rhs, &mut |v| (v == co_port).then_some(y), used))
                }
                Law::Explicit { rhs, .. } => {
                    let v = this.invert(node, rhs, co_port, energy, &[rate], used)?;
                    Some(this.argument(v, y))
                }
                _ => None,
            }
        };
        // (Made first: the pool's order of creation is the printed order of equal terms.)
        let state = (self.mode == Mode::Integral).then(|| {
            let index = StateIx::new(self.sys.states.len());
            self.sys.pool.leaf(Leaf::State(index))
        });
        let co_leaf = self.leaf(co);
        let derivative = inverse(self, co_leaf, &mut used).map(|g| (rate, g));
        let integral = match state {
            // The derivative form too, above: an element that another storage element drives
            // through a rigid path (a gear between inertias, capacitors in parallel) takes
            // derivative causality and holds no state.
            Some(state) => {
                let held = match phi(self, state, &mut used) {
                    Some(value) => Some((name, value, None)),
                    None => self
                        .co_energy_scale(law, co_port, state, &mut used)
                        .map(|scale| {
                            let name = format!("{}_{}", co_port.name(), self.model.node(node).name);
                            (name, state, Some(scale))
                        }),
                };
                let Some((name, value, scale)) = held else {
                    self.sys.refusals.push(Refusal {
                        element: node,
                        reason: format!(
                            "its law gives neither `{}` from `{}` nor a usable `{}` from `{}`, so it cannot hold a state (integral causality)",
                            co_port.name(),
                            energy.name(),
                            energy.name(),
                            co_port.name()
                        ),
                    });
                    return;
                };
                self.sys.states.push(State {
                    name,
                    element: node,
                    rate,
                    scale,
                });
                Some((co, value))
            }
            None => {
                let rate_leaf = self.leaf(rate);
                let integral_of_rate = self.sys.pool.int(rate_leaf);
                phi(self, integral_of_rate, &mut used).map(|h| (co, h))
            }
        };
        let implicit = match (&derivative, state) {
            (None, None) => {
                let x = self.sys.pool.leaf(ARGUMENT);
                phi(self, x, &mut used).map(|phi| (rate, phi))
            }
            _ => None,
        };
        if state.is_none() && derivative.is_none() && implicit.is_none() {
            self.sys.refusals.push(Refusal {
                element: node,
                reason: format!(
                    "its law gives `{}` from `{}` and has no closed-form inverse, so it cannot take derivative causality",
                    co_port.name(),
                    energy.name()
                ),
            });
        }
        used.sort();
        used.dedup();
        self.push(
            node,
            Relation::Storage {
                derivative,
                integral,
                implicit,
            },
            used,
        );
    }

    /// For a law `q = Φ(e)` (or `p = Φ(f)`) held through its co-energy variable `x` (the
    /// state's leaf): `dx/dt = rate / Φ'(x)`, and this is `1/Φ'(x)`.
    fn co_energy_scale(
        &mut self,
        law: &Law,
        co_port: PortVar,
        state: ExprId,
        used: &mut Vec<LetId>,
    ) -> Option<ExprId> {
        let Law::Explicit { output, rhs } = law else {
            return None;
        };
        if *output == co_port {
            return None;
        }
        let phi = self.expr(rhs, &mut |v| (v == co_port).then_some(state), used);
        let Node::Leaf(x) = self.sys.pool.node(state) else {
            return None;
        };
        // d/dx: the state's leaf moves at unit rate, parameters do not move.
        let mut d = Derivatives::new(move |p: &mut Pool, leaf: Leaf| match leaf {
            l if l == x => Some(p.num(1.0)),
            Leaf::Param(_) => Some(p.num(0.0)),
            _ => None,
        });
        let slope = d.of(&mut self.sys.pool, phi)?;
        // A law that does not follow its co-energy variable cannot give it.
        if self
            .sys
            .pool
            .as_num(slope)
            .is_some_and(|s| s == 0.0 || !s.is_finite())
        {
            return None;
        }
        let one = self.sys.pool.num(1.0);
        Some(self.sys.pool.div(one, slope))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::ParamId;

    fn leaf(s: Signal) -> Box<SignalExpr> {
        Box::new(Expr::Leaf(s))
    }

    /// A source scales a free `let` by a factor that names no `let`; anything else keeps its
    /// expression.
    #[test]
    fn a_source_scaling_a_free_let_is_recognised() {
        let (w, z, n) = (LetId(0), LetId(1), Signal::Param(ParamId(0)));
        let free = [w];
        let by = |e: SignalExpr| {
            scaled_let(&e, &free).map(|(l, k)| {
                (
                    l,
                    matches!(k, Scale::By(_)),
                    matches!(k, Scale::Over(_)),
                    match k {
                        Scale::Unit(x) => x,
                        _ => 0.0,
                    },
                )
            })
        };
        assert_eq!(by(Expr::Leaf(Signal::Let(w))), Some((w, false, false, 1.0)));
        assert_eq!(
            by(Expr::Neg(leaf(Signal::Let(w)))),
            Some((w, false, false, -1.0))
        );
        assert_eq!(
            by(Expr::Binary(BinOp::Mul, leaf(n), leaf(Signal::Let(w)))),
            Some((w, true, false, 0.0))
        );
        assert_eq!(
            by(Expr::Binary(BinOp::Mul, leaf(Signal::Let(w)), leaf(n))),
            Some((w, true, false, 0.0))
        );
        assert_eq!(
            by(Expr::Binary(BinOp::Div, leaf(Signal::Let(w)), leaf(n))),
            Some((w, false, true, 0.0))
        );
        // Not free, not a product, a factor naming a `let`, the `let` twice.
        assert_eq!(by(Expr::Leaf(Signal::Let(z))), None);
        assert_eq!(
            by(Expr::Binary(BinOp::Add, leaf(n), leaf(Signal::Let(w)))),
            None
        );
        assert_eq!(
            by(Expr::Binary(
                BinOp::Mul,
                leaf(Signal::Let(z)),
                leaf(Signal::Let(w))
            )),
            None
        );
        assert_eq!(
            by(Expr::Binary(
                BinOp::Mul,
                leaf(Signal::Let(w)),
                leaf(Signal::Let(w))
            )),
            None
        );
        assert_eq!(
            by(Expr::Binary(BinOp::Div, leaf(n), leaf(Signal::Let(w)))),
            None
        );
    }
}
