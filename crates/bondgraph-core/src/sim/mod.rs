//! State equations: the model in integral causality, dx/dt = f(x, u), and its detector outputs.

use std::collections::HashMap;

use crate::causality::equations::Var;
use crate::causality::{report, Causal};
use crate::diagnostic::{Code, Diagnostic, Severity};
use crate::graph::{BondGraph, NodeId, NodeKind};
use crate::symbolic::{ExprId, Leaf, Pool, Simplifier};

/// One state equation, `d(name)/dt = rhs`.
#[derive(Clone, Debug)]
pub struct StateEquation {
    /// `p_NAME` or `q_NAME`.
    pub name: String,
    /// The storage element.
    pub element: NodeId,
    /// The right-hand side, over states (`Leaf::State`), parameters, inputs and time.
    pub rhs: ExprId,
}

/// The state-space form of a model.
pub struct StateSpace {
    /// The expressions.
    pub pool: Pool,
    /// One equation per state, in declaration order of the storage elements.
    pub states: Vec<StateEquation>,
    /// Each detector's output, over states and inputs.
    pub outputs: Vec<(NodeId, ExprId)>,
    /// Why the state equations are incomplete, if they are.
    pub problems: Vec<Diagnostic>,
}

/// The state equations of `model` from its equations in integral causality.
pub fn state_space_of(model: &BondGraph, causal: &Causal) -> StateSpace {
    let mut pool = causal.system.pool.clone();
    let mut problems = report::refusals(model, causal);
    problems.extend(report::unsolved(model, causal));
    problems.extend(report::conflicts(model, causal));
    let nan = pool.num(f64::NAN);
    let mut outputs: Vec<(NodeId, ExprId)> = Vec::new();
    for id in model.nodes() {
        if let NodeKind::Detector(_) = model.node(id).kind {
            let value = model
                .detector_junction(id)
                .and_then(|j| causal.value(Var::Common(j)))
                .unwrap_or(nan);
            outputs.push((id, value));
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
    let states: Vec<StateEquation> = causal
        .system
        .states
        .clone()
        .into_iter()
        .map(|s| {
            let rhs = causal.solved.values[s.rate.0 as usize].unwrap_or(nan);
            StateEquation {
                name: s.name,
                element: s.element,
                rhs: measured(pool, rhs, &map),
            }
        })
        .collect();
    let mut simplifier = Simplifier::default();
    let mut states = states;
    for s in &mut states {
        s.rhs = simplifier.simplify(pool, s.rhs);
    }
    for (_, e) in &mut outputs {
        *e = simplifier.simplify(pool, *e);
    }
    let all: Vec<ExprId> = states
        .iter()
        .map(|s| s.rhs)
        .chain(outputs.iter().map(|o| o.1))
        .collect();
    let mut readers: Vec<NodeId> = Vec::new();
    for e in all {
        for l in pool.leaves(e) {
            if let Leaf::Sensor(s, _) = l {
                readers.push(s);
            }
        }
    }
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
        problems,
    }
}

fn measured(pool: &mut Pool, e: ExprId, outputs: &HashMap<NodeId, ExprId>) -> ExprId {
    pool.substitute(e, &mut |_, leaf| match leaf {
        Leaf::Sensor(s, 0) => outputs.get(&s).copied(),
        _ => None,
    })
}
