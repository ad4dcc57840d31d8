//! State equations: the model in integral causality, dx/dt = f(x, u), and its detector outputs.

use std::collections::HashMap;

use crate::causality::equations::{Relation, Var};
use crate::causality::solve::Use;
use crate::causality::{carried, report, Causal};
use crate::diagnostic::{Code, Diagnostic, Severity};
use crate::graph::{BondGraph, DetectorKind, NodeId, NodeKind};
use crate::symbolic::{ExprId, Leaf, Pool, Simplifier, StateIx, VarId};

/// One state equation, `d(name)/dt = rhs`.
#[derive(Clone, Debug)]
pub(crate) struct StateEquation {
    /// `p_NAME` or `q_NAME`; `e_NAME` or `f_NAME` for a co-energy state.
    pub name: String,
    /// The storage element.
    pub element: NodeId,
    /// Whether the state is the element's co-energy variable (its law gives `q` from `e`
    /// or `p` from `f`, with no closed-form inverse).
    pub co_energy: bool,
    /// The right-hand side, over states (`Leaf::State`), parameters, inputs and time.
    pub rhs: ExprId,
}

/// An unknown of a nonlinear algebraic loop that the state equations hold implicitly.
#[derive(Clone, Debug)]
pub(crate) struct LoopUnknown {
    /// Its symbol, `Leaf::Var(var)`, in the state equations and outputs.
    pub var: VarId,
    /// A name for it from the model's names: `e_b` for a 0-junction's effort, `f_a_r1` for
    /// a bond's flow.
    pub name: String,
    /// What it is, in words.
    pub description: String,
    /// The element whose law closes the loop.
    pub element: NodeId,
    /// `residual = 0` sets it, over states, inputs and the loops' unknowns.
    pub residual: ExprId,
}

/// The state-space form of a model.
pub(crate) struct StateSpace {
    /// The expressions.
    pub pool: Pool,
    /// One equation per state, in declaration order of the storage elements.
    pub states: Vec<StateEquation>,
    /// Each detector's output, over states and inputs.
    pub outputs: Vec<(NodeId, ExprId)>,
    /// The unknowns of nonlinear algebraic loops, each set by an equation of its own.
    pub implicit: Vec<LoopUnknown>,
    /// Why the state equations are incomplete, if they are.
    pub problems: Vec<Diagnostic>,
}

/// The state equations of `model` from its equations in integral causality.
pub(crate) fn state_space_of(model: &BondGraph, causal: &Causal) -> StateSpace {
    let mut pool = causal.system.pool.clone();
    let mut problems = report::refusals(model, causal);
    // What a refused law leaves unsolved follows from it: reported once, at the law.
    if problems.is_empty() {
        problems.extend(report::unsolved(model, causal));
    }
    problems.extend(report::conflicts(model, causal));
    let nan = pool.num(f64::NAN);
    let mut outputs: Vec<(NodeId, ExprId)> = Vec::new();
    // A `Dq` or `Dp` measures an integral: a state of its own, after the storage elements',
    // whose rate is the junction's variable.
    let mut integrands: Vec<(NodeId, ExprId)> = Vec::new();
    let storage = causal.system.states.len();
    for id in model.nodes() {
        if let NodeKind::Detector(kind) = model.node(id).kind {
            let value = model
                .detector_junction(id)
                .and_then(|j| causal.value(Var::Common(j)))
                .unwrap_or(nan);
            let faults = &model.node(id).faults;
            if kind.integrals() == 0 {
                outputs.push((id, carried::reading(&mut pool, faults, value)));
            } else {
                let state = StateIx((storage + integrands.len()) as u32);
                integrands.push((id, value));
                let state = pool.leaf(Leaf::State(state));
                outputs.push((id, carried::reading(&mut pool, faults, state)));
            }
        }
    }
    let pool = &mut pool;
    // Modulations may read detectors; replace measured signals by the outputs they measure.
    // Rounds until nothing changes: as many as the longest chain of detectors read by
    // modulations, usually none at all.
    for _ in 0..=outputs.len() {
        let reads = |pool: &Pool, e: ExprId| {
            pool.leaves(e)
                .iter()
                .any(|l| matches!(l, Leaf::Sensor(_, 0)))
        };
        if !outputs.iter().any(|(_, e)| reads(pool, *e)) {
            break;
        }
        let map: HashMap<NodeId, ExprId> = outputs.iter().copied().collect();
        for (_, e) in outputs.iter_mut() {
            *e = measured(pool, *e, &map);
        }
    }
    let map: HashMap<NodeId, ExprId> = outputs.iter().copied().collect();
    for (_, e) in integrands.iter_mut() {
        *e = measured(pool, *e, &map);
    }
    let mut kept = independent(causal);
    let mut states: Vec<StateEquation> = Vec::new();
    let mut rates: Vec<VarId> = Vec::new();
    for (s, _) in causal.system.states.iter().zip(&kept).filter(|(_, k)| **k) {
        let rhs = causal.solved.values[s.rate.index()].unwrap_or(nan);
        rates.push(s.rate);
        states.push(StateEquation {
            name: s.name.clone(),
            element: s.element,
            co_energy: s.scale.is_some(),
            rhs: measured(pool, rhs, &map),
        });
    }
    let mut implicit: Vec<LoopUnknown> = causal
        .solved
        .implicit
        .iter()
        .map(|i| {
            let var = causal.system.vars[i.var.index()];
            LoopUnknown {
                var: i.var,
                name: var.short_name(model),
                description: var.describe(model),
                element: causal.system.equations[i.equation].owner,
                residual: measured(pool, i.residual, &map),
            }
        })
        .collect();
    let mut simplifier = Simplifier::default();
    let holds_rates =
        |pool: &Pool, e: ExprId| pool.leaves(e).iter().any(|l| matches!(l, Leaf::Tear(..)));
    if let Some(l) = implicit.iter().find(|l| holds_rates(pool, l.residual)) {
        problems.push(report::at_nodes(
            model,
            Severity::Error,
            Code::AlgebraicLoop,
            &[l.element],
            format!(
                "the nonlinear algebraic loop closed by `{}` involves storage elements in derivative causality: not a state-space model bgc can simulate",
                model.node(l.element).name
            ),
        ));
    }
    let detectors = outputs.len();
    outputs.append(&mut integrands);
    let solved = solve_rates(pool, &mut states, &mut outputs, &rates);
    integrands = outputs.split_off(detectors);
    if let Err(element) = solved {
        problems.push(report::at_nodes(
            model,
            Severity::Error,
            Code::AlgebraicLoop,
            &[element],
            format!(
                "the derivative of `{}`'s state appears nonlinearly in the state equations, through storage elements in derivative causality",
                model.node(element).name
            ),
        ));
    }
    // A co-energy state x of `q = Φ(x)` moves at dq/dt / Φ'(x).
    let scales = causal.system.states.iter().zip(&kept).filter(|(_, k)| **k);
    for (s, (state, _)) in states.iter_mut().zip(scales) {
        if let Some(scale) = state.scale {
            s.rhs = pool.mul(s.rhs, scale);
        }
    }
    kept.resize(storage + integrands.len(), true);
    outputs.append(&mut integrands);
    renumber(pool, &mut states, &mut outputs, &mut implicit, &kept);
    for (detector, rate) in outputs.split_off(detectors) {
        states.push(measured_state(model, detector, rate));
    }
    for s in &mut states {
        s.rhs = simplifier.simplify(pool, s.rhs);
    }
    for l in &mut implicit {
        l.residual = simplifier.simplify(pool, l.residual);
    }
    for (_, e) in &mut outputs {
        *e = simplifier.simplify(pool, *e);
    }
    let all: Vec<ExprId> = states
        .iter()
        .map(|s| s.rhs)
        .chain(outputs.iter().map(|o| o.1))
        .chain(implicit.iter().map(|l| l.residual))
        .collect();
    let mut readers: Vec<NodeId> = Vec::new();
    for e in all {
        for l in pool.leaves(e) {
            if let Leaf::Sensor(s, _) = l {
                readers.push(s);
            }
        }
    }
    readers.sort();
    readers.dedup();
    if !readers.is_empty() {
        let names: Vec<String> = readers
            .iter()
            .map(|&s| format!("`{}`", model.node(s).name))
            .collect();
        problems.push(report::at_nodes(
            model,
            Severity::Error,
            Code::Refused,
            &readers,
            format!(
                "a modulation reads the measured signal(s) {}, which depend on themselves or are differentiated: \
                 not a state-space model",
                names.join(", ")
            ),
        ));
    }
    StateSpace {
        pool: std::mem::take(pool),
        states,
        outputs,
        implicit,
        problems,
    }
}

/// The state a `Dq` or `Dp` detector measures: `q_NAME` or `p_NAME`, moving at `rate`.
fn measured_state(model: &BondGraph, detector: NodeId, rate: ExprId) -> StateEquation {
    let node = model.node(detector);
    let prefix = match node.kind {
        NodeKind::Detector(DetectorKind::Dp) => "p",
        _ => "q",
    };
    StateEquation {
        name: format!("{prefix}_{}", node.name),
        element: detector,
        co_energy: false,
        rhs: rate,
    }
}

/// Which states are independent: those whose storage element took integral causality. A
/// storage element in derivative causality (an inertia behind a rigid gear) holds none.
fn independent(causal: &Causal) -> Vec<bool> {
    // The storage equation that set each element's co-energy variable from its state.
    let mut integral: HashMap<NodeId, bool> = HashMap::new();
    for (i, eq) in causal.system.equations.iter().enumerate() {
        if let (
            Relation::Storage {
                integral: Some((co, _)),
                ..
            },
            Use::Solves { var, .. },
        ) = (&eq.relation, causal.solved.uses[i])
        {
            if *co == var {
                integral.insert(eq.owner, true);
            }
        }
    }
    causal
        .system
        .states
        .iter()
        .map(|s| integral.contains_key(&s.element))
        .collect()
}

/// Solves the state equations for the state derivatives they hold (`Tear(rate, 0)`: a
/// storage element in derivative causality differentiates states), when they enter linearly:
/// Gaussian elimination, one rate at a time. `Err` names the element whose rate does not.
fn solve_rates(
    pool: &mut Pool,
    states: &mut [StateEquation],
    outputs: &mut [(NodeId, ExprId)],
    rates: &[VarId],
) -> Result<(), NodeId> {
    let holds = |pool: &Pool, e: ExprId| pool.leaves(e).iter().any(|l| matches!(l, Leaf::Tear(..)));
    if !states.iter().any(|s| holds(pool, s.rhs)) && !outputs.iter().any(|o| holds(pool, o.1)) {
        return Ok(());
    }
    let mut simplifier = Simplifier::default();
    // rate_k - rhs_k = 0, with each solved rate substituted into the others as it is found.
    let mut solved: Vec<(Leaf, ExprId)> = Vec::new();
    for k in 0..states.len() {
        let x = Leaf::Tear(rates[k], 0);
        let own = pool.leaf(x);
        let equation = pool.sub(own, states[k].rhs);
        let equation = simplifier.simplify(pool, equation);
        let root = crate::symbolic::linear_root_of(pool, equation, x).ok_or(states[k].element)?;
        for (_, value) in &mut solved {
            *value = pool.substitute(*value, &mut |_, l| (l == x).then_some(root));
        }
        solved.push((x, root));
        for s in states.iter_mut().skip(k + 1) {
            s.rhs = pool.substitute(s.rhs, &mut |_, l| (l == x).then_some(root));
        }
    }
    let put = |pool: &mut Pool, e: ExprId| {
        pool.substitute(e, &mut |_, l| {
            solved.iter().find(|(x, _)| *x == l).map(|(_, v)| *v)
        })
    };
    for (s, (_, value)) in states.iter_mut().zip(&solved) {
        s.rhs = *value;
    }
    for (_, e) in outputs.iter_mut() {
        *e = put(pool, *e);
    }
    Ok(())
}

/// Renumbers `Leaf::State` to the independent states only.
pub(crate) fn renumber(
    pool: &mut Pool,
    states: &mut [StateEquation],
    outputs: &mut [(NodeId, ExprId)],
    implicit: &mut [LoopUnknown],
    kept: &[bool],
) {
    if kept.iter().all(|k| *k) {
        return;
    }
    let mut index = Vec::with_capacity(kept.len());
    let mut next = 0u32;
    for &k in kept {
        index.push(StateIx(next));
        next += u32::from(k);
    }
    let map = |pool: &mut Pool, e: ExprId| {
        pool.substitute(e, &mut |p, l| match l {
            Leaf::State(k) => Some(p.leaf(Leaf::State(index[k.index()]))),
            _ => None,
        })
    };
    for s in states.iter_mut() {
        s.rhs = map(pool, s.rhs);
    }
    for (_, e) in outputs.iter_mut() {
        *e = map(pool, *e);
    }
    for l in implicit.iter_mut() {
        l.residual = map(pool, l.residual);
    }
}

fn measured(pool: &mut Pool, e: ExprId, outputs: &HashMap<NodeId, ExprId>) -> ExprId {
    pool.substitute(e, &mut |_, leaf| match leaf {
        Leaf::Sensor(s, 0) => outputs.get(&s).copied(),
        _ => None,
    })
}
