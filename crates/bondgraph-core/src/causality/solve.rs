//! Orienting the equations: each unknown is computed from one equation, in an order where
//! everything it needs is known first. Equations left over once all their unknowns are known
//! are redundant: the analytical redundancy relations.
//!
//! The order follows SCAP: sources and inverted detectors, with what junctions, TF and GY
//! propagate from them, first; then storage in the preferred causality; then resistors. In
//! diagnosis the balance of a junction that carries a detector comes next: it is the junction
//! the detector makes over-determined, so it becomes the ARR whenever the rest of the graph
//! allows, and is solved for an unknown (as the reference paper does for the motor torque)
//! only before the last resort, storage in integral causality. Integral causality is last
//! because an ARR with `int(..)` holds only for known initial energy (zero, here), which a
//! residual on a running machine cannot assume. Each step is O(degree of the equation).

use std::collections::VecDeque;

use super::equations::{Equation, Relation, System, VarId, ARGUMENT};
use super::mode::Mode;
use crate::graph::{BondGraph, ElementKind, NodeKind};
use crate::index::Idx as _;
use crate::symbolic::{known_signal_rule, linear_root_of, Derivatives, ExprId, Leaf, Pool, RootIx};

/// Why an equation was used to compute an unknown (lower is preferred).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Class {
    /// Sources, inverted detectors, junctions, TF, GY.
    Structural = 0,
    /// Storage in the mode's preferred causality.
    Preferred = 1,
    /// A resistor.
    Resistor = 2,
    /// The balance of a junction that carries a detector (diagnosis).
    SensorBalance = 3,
    /// A nonlinear law read through its closed-form inverse: after every way of using it
    /// as written, whose conditioning the user chose (`f = Kv e^3` stays a cube, not a
    /// cube root of a signal near zero).
    Inverted = 4,
    /// A nonlinear law with no closed-form inverse read for its input (diagnosis): the
    /// input becomes a [`Root`], found numerically at run time. Before integral causality,
    /// whose ARRs hold only from a known initial state.
    Implicit = 5,
    /// Storage in the other causality (integral in diagnosis).
    Fallback = 6,
}

/// What became of an equation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Use {
    /// Still waiting: some unknown of it could not be computed.
    Pending,
    /// It computes `var`.
    Solves {
        /// The unknown.
        var: VarId,
        /// Which rule of the order chose it.
        class: Class,
    },
    /// All its unknowns were computed elsewhere: `residual = 0` must hold.
    Redundant {
        /// The residual, over known signals.
        residual: ExprId,
    },
}

/// An unknown computed from a measured junction's balance, held as the symbol
/// [`Leaf::Tear`] downstream, so that each ARR holds only what its own part of the graph says
/// (see [`crate::fdi::eliminate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Torn {
    /// The unknown.
    pub var: VarId,
    /// The balance that computes it, and its value over known signals and earlier torn
    /// unknowns; `None` for an unknown torn where propagation stalled in diagnosis (the
    /// velocity of an unmeasured mass between measured ones), which only the relations
    /// that hold it determine.
    pub definition: Option<(usize, ExprId)>,
}

/// An unknown of a nonlinear algebraic loop (integral causality only): held as the symbol
/// [`Leaf::Var`] wherever it is read, and set by `residual = 0`, which has no closed-form
/// root; a simulation finds it numerically.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Implicit {
    /// The unknown.
    pub var: VarId,
    /// The equation that closes its loop.
    pub equation: usize,
    /// That equation's residual, over known signals and the loops' unknowns.
    pub residual: ExprId,
}

/// An unknown set by a law that has no closed-form inverse (diagnosis only): held as the
/// symbol [`Leaf::Root`] wherever it is read, it is the root of `residual`, which a residual
/// generator finds numerically at each sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Root {
    /// The unknown (for a storage element read through its law, the rate is the root's
    /// derivative and the unknown the root's is the energy variable).
    pub var: VarId,
    /// The law's equation.
    pub equation: usize,
    /// `law(root) − given`, over known signals, earlier roots and the root itself.
    pub residual: ExprId,
}

/// The oriented system.
pub(crate) struct Solved {
    /// Each unknown's expression over known signals, when it could be computed.
    pub values: Vec<Option<ExprId>>,
    /// What became of each equation.
    pub uses: Vec<Use>,
    /// The equation that computes each unknown.
    pub solved_by: Vec<Option<usize>>,
    /// The unknowns held as symbols, in the order they were computed.
    pub torn: Vec<Torn>,
    /// The unknowns of nonlinear algebraic loops, in the order they were torn.
    pub implicit: Vec<Implicit>,
    /// The unknowns set numerically, by the index of their [`Leaf::Root`].
    pub roots: Vec<Root>,
}

fn class_of(
    model: &BondGraph,
    sensed: &[bool],
    eq: &Equation,
    v: VarId,
    mode: Mode,
) -> Option<Class> {
    let is_resistor = matches!(
        model.node(eq.owner).kind,
        NodeKind::Element(ElementKind::R | ElementKind::MR, _)
    );
    match &eq.relation {
        Relation::Assign { var, .. } => (*var == v).then_some(Class::Structural),
        Relation::Scale { a, b, .. } if *a == v || *b == v => Some(if is_resistor {
            Class::Resistor
        } else {
            Class::Structural
        }),
        Relation::Scale { .. } => None,
        Relation::Law { out, .. } if *out == v => Some(Class::Resistor),
        Relation::Law { inverse: None, .. } => (mode == Mode::Diagnosis).then_some(Class::Implicit),
        Relation::Law { inverse, .. } => {
            inverse.is_some_and(|i| i.0 == v).then_some(Class::Inverted)
        }
        Relation::Sum { terms } => terms.iter().any(|t| t.1 == v).then_some(
            if mode == Mode::Diagnosis && sensed[eq.owner.0.index()] {
                Class::SensorBalance
            } else {
                Class::Structural
            },
        ),
        Relation::Storage {
            derivative,
            integral,
            implicit,
        } => {
            if implicit.is_some_and(|d| d.0 == v) && mode == Mode::Diagnosis {
                Some(Class::Implicit)
            } else if derivative.is_some_and(|d| d.0 == v) {
                Some(if mode == Mode::Diagnosis {
                    Class::Preferred
                } else {
                    Class::Fallback
                })
            } else if integral.is_some_and(|i| i.0 == v) {
                Some(if mode == Mode::Diagnosis {
                    Class::Fallback
                } else {
                    Class::Preferred
                })
            } else {
                None
            }
        }
    }
}

/// Orients `sys` by propagation from what is known, tearing linear algebraic loops.
pub(crate) fn solve(model: &BondGraph, sys: &mut System, mode: Mode) -> Solved {
    let mut solver = Solver::new(model, sys, mode);
    for i in 0..solver.sys.equations.len() {
        solver.settle(i);
    }
    solver.propagate();
    // Each tear either solves a loop or is undone; a loop it cannot solve stays reported.
    // Undoing costs a pass over the equations, so attempts are capped.
    let mut tried = std::collections::BTreeSet::new();
    let mut tried_implicit = std::collections::BTreeSet::new();
    loop {
        while let Some(v) = solver
            .tear_candidate(&tried)
            .filter(|_| tried.len() < MAX_TEARS)
        {
            tried.insert(v);
            solver.tear(v, false);
        }
        // What linear tears leave of a loop in integral causality is held implicitly, one
        // unknown per loop; then the rest may have become linear.
        let next = (mode == Mode::Integral)
            .then(|| solver.tear_candidate(&tried_implicit))
            .flatten()
            .filter(|_| tried_implicit.len() < MAX_TEARS);
        let Some(v) = next else { break };
        tried_implicit.insert(v);
        solver.tear(v, true);
    }
    Solved {
        values: solver.values,
        uses: solver.uses,
        solved_by: solver.solved_by,
        torn: solver.torn,
        implicit: solver.implicit,
        roots: solver.roots,
    }
}

/// Most tears tried on one model.
const MAX_TEARS: usize = 1000;

/// The propagation state.
struct Solver<'a> {
    model: &'a BondGraph,
    sys: &'a mut System,
    mode: Mode,
    sensed: Vec<bool>,
    var_eqs: Vec<Vec<usize>>,
    unknown: Vec<usize>,
    values: Vec<Option<ExprId>>,
    uses: Vec<Use>,
    solved_by: Vec<Option<usize>>,
    torn: Vec<Torn>,
    implicit: Vec<Implicit>,
    roots: Vec<Root>,
    queues: [VecDeque<usize>; 7],
    derivatives: Derivatives<Leaf, Rule>,
    /// While a tear is tried: the unknowns and equations it touched, to undo it.
    journal: Option<(Vec<usize>, Vec<usize>)>,
}

impl<'a> Solver<'a> {
    fn new(model: &'a BondGraph, sys: &'a mut System, mode: Mode) -> Self {
        let n_vars = sys.vars.len();
        let mut var_eqs: Vec<Vec<usize>> = vec![Vec::new(); n_vars];
        for (i, eq) in sys.equations.iter().enumerate() {
            for v in &eq.vars {
                var_eqs[v.index()].push(i);
            }
        }
        // Junctions that carry a detector.
        let mut sensed = vec![false; model.graph.node_count()];
        for junction in model.nodes().filter_map(|id| model.detector_junction(id)) {
            sensed[junction.0.index()] = true;
        }
        let rule = rule(sys, mode);
        Solver {
            model,
            unknown: sys.equations.iter().map(|e| e.vars.len()).collect(),
            uses: vec![Use::Pending; sys.equations.len()],
            values: vec![None; n_vars],
            solved_by: vec![None; n_vars],
            torn: Vec::new(),
            implicit: Vec::new(),
            roots: Vec::new(),
            sys,
            mode,
            sensed,
            var_eqs,
            queues: Default::default(),
            derivatives: Derivatives::new(rule),
            journal: None,
        }
    }

    /// Queues a pending equation with one unknown, or records it as redundant with none.
    fn settle(&mut self, i: usize) {
        if self.uses[i] != Use::Pending {
            return;
        }
        if self.unknown_state_output(i).is_some() {
            // Integral causality needs only the state, whatever the rate is.
            self.queues[Class::Preferred as usize].push_back(i);
            return;
        }
        match self.unknown[i] {
            0 => {
                let r = match self.implicit_rate(i) {
                    // `rate = d/dt root`: the storage law as given, with no integral.
                    Some(rate) => match self.root(i, rate) {
                        Some(d) => {
                            let known = value_of(&mut self.sys.pool, rate, &self.values);
                            self.sys.pool.sub(known, d)
                        }
                        None => residual(self.sys, i, &self.values, &mut self.derivatives),
                    },
                    None => residual(self.sys, i, &self.values, &mut self.derivatives),
                };
                self.set_use(i, Use::Redundant { residual: r });
            }
            1 => {
                let eq = &self.sys.equations[i];
                if let Some(&v) = eq.vars.iter().find(|v| self.values[v.index()].is_none()) {
                    if let Some(class) = class_of(self.model, &self.sensed, eq, v, self.mode) {
                        self.queues[class as usize].push_back(i);
                    }
                }
            }
            _ => {}
        }
    }

    fn set_use(&mut self, i: usize, u: Use) {
        self.uses[i] = u;
        if let Some((_, eqs)) = &mut self.journal {
            eqs.push(i);
        }
    }

    /// Records the value of `v` and lets the equations that use it move on.
    fn know(&mut self, v: VarId, value: ExprId, by: Option<usize>) {
        self.values[v.index()] = Some(value);
        self.solved_by[v.index()] = by;
        if let Some((vars, _)) = &mut self.journal {
            vars.push(v.index());
        }
        for k in 0..self.var_eqs[v.index()].len() {
            let j = self.var_eqs[v.index()][k];
            self.unknown[j] -= 1;
            self.settle(j);
        }
    }

    /// The next equation to orient. In diagnosis, storage is put in integral causality only
    /// when no unknown can be torn instead: a chain of unmeasured masses between measured
    /// ones is then related by elimination over d/dt, not by integrals of unknowns.
    fn next(&mut self) -> Option<usize> {
        let fallback = Class::Fallback as usize;
        loop {
            if let Some(i) = self.queues[..fallback]
                .iter_mut()
                .find_map(VecDeque::pop_front)
            {
                return Some(i);
            }
            if self.mode == Mode::Diagnosis && self.journal.is_none() && self.tear_differential() {
                continue;
            }
            return self.queues[fallback].pop_front();
        }
    }

    /// Holds an unknown of a stalled equation as a differential symbol; `false` if none is
    /// left to tear.
    fn tear_differential(&mut self) -> bool {
        if self.torn.len() >= MAX_TEARS {
            return false;
        }
        let Some(v) = self.tear_candidate(&std::collections::BTreeSet::new()) else {
            return false;
        };
        let symbol = self.sys.pool.leaf(Leaf::Tear(v, 0));
        self.torn.push(Torn {
            var: v,
            definition: None,
        });
        self.know(v, symbol, None);
        true
    }

    /// In integral causality, the co-energy variable of a storage element's equation while
    /// it is unknown: the state gives it, whether or not the rate is known.
    fn unknown_state_output(&self, i: usize) -> Option<VarId> {
        if self.mode != Mode::Integral {
            return None;
        }
        match self.sys.equations[i].relation {
            Relation::Storage {
                integral: Some((co, _)),
                ..
            } if self.values[co.index()].is_none() => Some(co),
            _ => None,
        }
    }

    fn propagate(&mut self) {
        while let Some(i) = self.next() {
            if self.uses[i] != Use::Pending {
                continue;
            }
            let state_output = self.unknown_state_output(i);
            if state_output.is_none() && self.unknown[i] != 1 {
                continue;
            }
            let eq = &self.sys.equations[i];
            let Some(v) = state_output.or_else(|| {
                eq.vars
                    .iter()
                    .copied()
                    .find(|v| self.values[v.index()].is_none())
            }) else {
                continue;
            };
            let Some(class) = class_of(self.model, &self.sensed, eq, v, self.mode) else {
                continue;
            };
            let mut value = if class == Class::Implicit {
                match self.root(i, v) {
                    Some(value) => value,
                    None => continue,
                }
            } else {
                solve_for(self.sys, i, v, &self.values, &mut self.derivatives)
            };
            if class == Class::SensorBalance {
                self.torn.push(Torn {
                    var: v,
                    definition: Some((i, value)),
                });
                value = self.sys.pool.leaf(Leaf::Tear(v, 0));
            }
            self.set_use(i, Use::Solves { var: v, class });
            self.know(v, value, Some(i));
        }
    }

    /// In diagnosis, the rate of a storage equation that has only its implicit derivative
    /// form: checked as the derivative of a root rather than through an integral from the
    /// start of the record.
    fn implicit_rate(&self, i: usize) -> Option<VarId> {
        match self.sys.equations[i].relation {
            Relation::Storage {
                derivative: None,
                implicit: Some((rate, _)),
                ..
            } if self.mode == Mode::Diagnosis => Some(rate),
            _ => None,
        }
    }

    /// Holds the unknown `v` of equation `i`, a law with no closed-form inverse read for
    /// its input, as a new root; its value (the root, or for a storage element's rate the
    /// root's derivative). `None`, and the equation waits for integral causality, while a
    /// tear is tried (it could not be undone) or when what the law is given over holds a
    /// torn unknown, whose elimination cannot reach inside a root.
    fn root(&mut self, i: usize, v: VarId) -> Option<ExprId> {
        if self.journal.is_some() {
            return None;
        }
        let k = RootIx::new(self.roots.len());
        let pool = &mut self.sys.pool;
        let z = pool.leaf(Leaf::Root(k, 0));
        let (given, law, value) = match self.sys.equations[i].relation.clone() {
            Relation::Law { out, rhs, .. } => {
                let law = pool.substitute(rhs, &mut |_, l| (l == Leaf::Var(v)).then_some(z));
                (out, law, z)
            }
            Relation::Storage {
                implicit: Some((rate, phi)),
                integral: Some((co, _)),
                ..
            } if rate == v => {
                let law = pool.substitute(phi, &mut |_, l| (l == ARGUMENT).then_some(z));
                (co, law, pool.leaf(Leaf::Root(k, 1)))
            }
            _ => return None,
        };
        let law = known(pool, law, &self.values);
        let given = value_of(pool, given, &self.values);
        let residual = pool.sub(law, given);
        // A measured junction's unknown whose value reads known signals only is that value:
        // the root's law must be over known signals, which elimination does not look into.
        let torn = &self.torn;
        let residual = pool.substitute(residual, &mut |_, l| match l {
            Leaf::Tear(u, 0) => torn
                .iter()
                .find(|t| t.var == u)
                .and_then(|t| t.definition)
                .map(|d| d.1),
            _ => None,
        });
        let leaves = pool.leaves(residual);
        let opaque = leaves
            .iter()
            .any(|l| matches!(l, Leaf::Tear(..) | Leaf::Var(_)));
        if opaque || !leaves.contains(&Leaf::Root(k, 0)) || !smooth_in(pool, residual, z) {
            return None;
        }
        self.roots.push(Root {
            var: v,
            equation: i,
            residual,
        });
        Some(value)
    }

    /// An unknown to tear a stalled loop at: the first unknown of the first waiting
    /// equation that has two, never one already tried.
    fn tear_candidate(&self, tried: &std::collections::BTreeSet<VarId>) -> Option<VarId> {
        self.sys.equations.iter().enumerate().find_map(|(i, eq)| {
            (self.uses[i] == Use::Pending && self.unknown[i] == 2)
                .then(|| {
                    eq.vars
                        .iter()
                        .copied()
                        .find(|v| self.values[v.index()].is_none() && !tried.contains(v))
                })
                .flatten()
        })
    }

    /// Assumes `v` known as a symbol, propagates, and solves for it from the first equation
    /// that closes the loop, if that equation is linear in `v`; otherwise, when `implicit`,
    /// keeps `v` as the loop's implicit unknown, and else undoes everything.
    fn tear(&mut self, v: VarId, implicit: bool) {
        self.journal = Some((Vec::new(), Vec::new()));
        let symbol = self.sys.pool.leaf(Leaf::Var(v));
        self.know(v, symbol, None);
        self.propagate();
        let Some((vars, eqs)) = self.journal.take() else {
            return;
        };
        let closing = eqs.iter().copied().find(|&i| match self.uses[i] {
            Use::Redundant { residual } => self.sys.pool.leaves(residual).contains(&Leaf::Var(v)),
            _ => false,
        });
        let solution = closing.and_then(|i| match self.uses[i] {
            Use::Redundant { residual } => linear_root(&mut self.sys.pool, residual, v),
            _ => None,
        });
        match (closing, solution) {
            (Some(i), Some(value)) => {
                let pool = &mut self.sys.pool;
                let mut put = |e: ExprId| {
                    pool.substitute(e, &mut |_, leaf| (leaf == Leaf::Var(v)).then_some(value))
                };
                for &k in &vars {
                    if let Some(e) = self.values[k] {
                        self.values[k] = Some(put(e));
                    }
                }
                for t in &mut self.torn {
                    if let Some((_, value)) = &mut t.definition {
                        *value = put(*value);
                    }
                }
                for &j in &eqs {
                    if let Use::Redundant { residual } = self.uses[j] {
                        self.uses[j] = Use::Redundant {
                            residual: put(residual),
                        };
                    }
                }
                self.values[v.index()] = Some(value);
                self.solved_by[v.index()] = Some(i);
                self.uses[i] = Use::Solves {
                    var: v,
                    class: Class::Structural,
                };
                self.propagate();
            }
            (Some(i), None) if implicit => {
                if let Use::Redundant { residual } = self.uses[i] {
                    self.implicit.push(Implicit {
                        var: v,
                        equation: i,
                        residual,
                    });
                }
                self.solved_by[v.index()] = Some(i);
                self.uses[i] = Use::Solves {
                    var: v,
                    class: Class::Structural,
                };
            }
            _ => self.undo(&vars, &eqs),
        }
    }

    fn undo(&mut self, vars: &[usize], eqs: &[usize]) {
        for &k in vars {
            self.values[k] = None;
            self.solved_by[k] = None;
        }
        for &j in eqs {
            self.uses[j] = Use::Pending;
        }
        self.torn.retain(|t| self.values[t.var.index()].is_some());
        for (i, eq) in self.sys.equations.iter().enumerate() {
            self.unknown[i] = eq
                .vars
                .iter()
                .filter(|v| self.values[v.index()].is_none())
                .count();
        }
        self.queues = Default::default();
    }
}

/// Whether `e` follows the leaf `z` through smooth functions only: a law that reaches its
/// input through `abs`, `sign`, `min`, `max`, a periodic function or an integral has flat
/// stretches or several inputs per value, where a numerical root is no answer.
fn smooth_in(pool: &Pool, e: ExprId, z: ExprId) -> bool {
    use crate::expr::Func;
    use crate::symbolic::Node;
    let mut holds = std::collections::HashSet::new();
    let mut smooth = true;
    pool.visit_reachable(&[e], |id, node| {
        let held = |a: ExprId| a == z || holds.contains(&a);
        let rough = match node {
            Node::Call1(Func::Abs | Func::Sign | Func::Sin | Func::Cos | Func::Tan, a)
            | Node::Int(a) => held(a),
            Node::Call2(_, a, b) => held(a) || held(b),
            _ => false,
        };
        smooth &= !rough;
        if id == z || crate::symbolic::children(node).any(held) {
            holds.insert(id);
        }
    });
    smooth
}

/// The root of `r`, if `r` is linear in the unknown `v`: with a = r(0) and b = r(1) − a,
/// r is linear when r(2) = a + 2b holds in canonical form, and then v = −a/b.
fn linear_root(pool: &mut Pool, r: ExprId, v: VarId) -> Option<ExprId> {
    linear_root_of(pool, r, Leaf::Var(v))
}

/// `e` with every unknown replaced by its value.
fn known(pool: &mut Pool, e: ExprId, values: &[Option<ExprId>]) -> ExprId {
    pool.substitute(e, &mut |p, leaf| match leaf {
        Leaf::Var(v) => Some(values[v.index()].unwrap_or_else(|| p.num(f64::NAN))),
        _ => None,
    })
}

fn value_of(pool: &mut Pool, v: VarId, values: &[Option<ExprId>]) -> ExprId {
    values[v.index()].unwrap_or_else(|| pool.num(f64::NAN))
}

/// How leaves vary in time while the equations are oriented: known signals get derivatives
/// of their own; in integral causality a state's derivative is its rate, an unknown held as
/// the symbol `Tear(rate, 0)` until the state equations are solved for it.
type Rule = Box<dyn FnMut(&mut Pool, Leaf) -> Option<ExprId>>;

fn rule(sys: &System, mode: Mode) -> Rule {
    match mode {
        Mode::Diagnosis => Box::new(known_signal_rule),
        Mode::Integral => {
            let rates: Vec<(VarId, Option<ExprId>)> =
                sys.states.iter().map(|s| (s.rate, s.scale)).collect();
            Box::new(move |p: &mut Pool, leaf: Leaf| match leaf {
                Leaf::State(k) => rates.get(k.index()).map(|&(r, scale)| {
                    let rate = p.leaf(Leaf::Tear(r, 0));
                    // A co-energy state moves at rate/Φ'(x).
                    match scale {
                        Some(s) => p.mul(rate, s),
                        None => rate,
                    }
                }),
                Leaf::Tear(v, n) => Some(p.leaf(Leaf::Tear(v, n + 1))),
                other => known_signal_rule(p, other),
            })
        }
    }
}

fn differentiate(pool: &mut Pool, e: ExprId, d: &mut Derivatives<Leaf, Rule>) -> ExprId {
    d.of(pool, e).unwrap_or_else(|| pool.num(f64::NAN))
}

fn solve_for(
    sys: &mut System,
    i: usize,
    v: VarId,
    values: &[Option<ExprId>],
    d: &mut Derivatives<Leaf, Rule>,
) -> ExprId {
    let relation = sys.equations[i].relation.clone();
    let p = &mut sys.pool;
    match relation {
        Relation::Assign { value, .. } => known(p, value, values),
        Relation::Scale { a, b, k } => {
            let k = known(p, k, values);
            if v == a {
                let b = value_of(p, b, values);
                p.mul(k, b)
            } else {
                let a = value_of(p, a, values);
                p.div(a, k)
            }
        }
        Relation::Law { out, rhs, inverse } => match inverse {
            Some((input, value)) if input == v && out != v => known(p, value, values),
            _ => known(p, rhs, values),
        },
        Relation::Sum { terms } => {
            let own = terms.iter().find(|t| t.1 == v).is_none_or(|t| t.0);
            // own·v + Σ others = 0  ⇒  v = Σ (−sign) others, with own's sign folded in.
            let others: Vec<(bool, ExprId)> = terms
                .iter()
                .filter(|t| t.1 != v)
                .map(|&(plus, w)| (plus != own, value_of(p, w, values)))
                .collect();
            p.signed_sum(&others)
        }
        Relation::Storage {
            derivative,
            integral,
            ..
        } => match (derivative, integral) {
            (Some((out, g)), _) if out == v => {
                let g = known(p, g, values);
                differentiate(p, g, d)
            }
            (_, Some((_, h))) => known(p, h, values),
            _ => p.num(f64::NAN),
        },
    }
}

/// The residual of an equation whose unknowns are all known.
fn residual(
    sys: &mut System,
    i: usize,
    values: &[Option<ExprId>],
    d: &mut Derivatives<Leaf, Rule>,
) -> ExprId {
    let relation = sys.equations[i].relation.clone();
    let p = &mut sys.pool;
    match relation {
        Relation::Assign { var, value } => {
            let x = value_of(p, var, values);
            let value = known(p, value, values);
            p.sub(x, value)
        }
        Relation::Scale { a, b, k } => {
            let (a, b) = (value_of(p, a, values), value_of(p, b, values));
            let k = known(p, k, values);
            let kb = p.mul(k, b);
            p.sub(a, kb)
        }
        Relation::Law { out, rhs, .. } => {
            let out = value_of(p, out, values);
            let rhs = known(p, rhs, values);
            p.sub(out, rhs)
        }
        Relation::Sum { terms } => {
            let terms: Vec<(bool, ExprId)> = terms
                .iter()
                .map(|&(plus, w)| (plus, value_of(p, w, values)))
                .collect();
            p.signed_sum(&terms)
        }
        Relation::Storage {
            derivative,
            integral,
            ..
        } => match (derivative, integral) {
            (Some((out, g)), _) => {
                let out = value_of(p, out, values);
                let g = known(p, g, values);
                let dg = differentiate(p, g, d);
                p.sub(out, dg)
            }
            (None, Some((out, h))) => {
                let out = value_of(p, out, values);
                let h = known(p, h, values);
                p.sub(out, h)
            }
            (None, None) => p.num(0.0),
        },
    }
}
