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

use super::equations::{Equation, Relation, System, VarId};
use super::Mode;
use crate::graph::{BondGraph, ElementKind, NodeKind};
use crate::symbolic::{known_signal_rule, Derivatives, ExprId, Leaf, Pool};

/// Why an equation was used to compute an unknown (lower is preferred).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Class {
    /// Sources, inverted detectors, junctions, TF, GY.
    Structural = 0,
    /// Storage in the mode's preferred causality.
    Preferred = 1,
    /// A resistor.
    Resistor = 2,
    /// The balance of a junction that carries a detector (diagnosis).
    SensorBalance = 3,
    /// Storage in the other causality (integral in diagnosis).
    Fallback = 4,
}

/// What became of an equation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Use {
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

/// The oriented system.
pub struct Solved {
    /// Each unknown's expression over known signals, when it could be computed.
    pub values: Vec<Option<ExprId>>,
    /// What became of each equation.
    pub uses: Vec<Use>,
    /// The equation that computes each unknown.
    pub solved_by: Vec<Option<usize>>,
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
        NodeKind::Element(ElementKind::R, _)
    );
    match &eq.relation {
        Relation::Assign { var, .. } => (*var == v).then_some(Class::Structural),
        Relation::Scale { a, b, .. } if *a == v || *b == v => Some(if is_resistor {
            Class::Resistor
        } else {
            Class::Structural
        }),
        Relation::Scale { .. } => None,
        Relation::Law { out, .. } => (*out == v).then_some(Class::Resistor),
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
        } => {
            if derivative.is_some_and(|d| d.0 == v) {
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

/// Orients `sys` by propagation from what is known.
pub fn solve(model: &BondGraph, sys: &mut System, mode: Mode) -> Solved {
    let n_vars = sys.vars.len();
    let mut var_eqs: Vec<Vec<usize>> = vec![Vec::new(); n_vars];
    for (i, eq) in sys.equations.iter().enumerate() {
        for v in &eq.vars {
            var_eqs[v.0 as usize].push(i);
        }
    }
    let mut unknown: Vec<usize> = sys.equations.iter().map(|e| e.vars.len()).collect();
    let mut values: Vec<Option<ExprId>> = vec![None; n_vars];
    let mut uses = vec![Use::Pending; sys.equations.len()];
    let mut solved_by = vec![None; n_vars];
    let mut queues: [VecDeque<usize>; 5] = Default::default();
    // Junctions that carry a detector.
    let mut sensed = vec![false; model.graph.node_count()];
    for id in model.nodes() {
        if let NodeKind::Detector(_) = model.node(id).kind {
            for b in model.bonds_at(id, petgraph::Direction::Incoming) {
                sensed[model.ends(b).0 .0.index()] = true;
            }
        }
    }
    let mut derivatives = Derivatives::new(known_signal_rule as Rule);

    let enqueue =
        |queues: &mut [VecDeque<usize>; 5], i: usize, sys: &System, values: &[Option<ExprId>]| {
            let eq = &sys.equations[i];
            if let Some(&v) = eq.vars.iter().find(|v| values[v.0 as usize].is_none()) {
                if let Some(class) = class_of(model, &sensed, eq, v, mode) {
                    queues[class as usize].push_back(i);
                }
            }
        };
    for i in 0..sys.equations.len() {
        match unknown[i] {
            0 => {
                uses[i] = Use::Redundant {
                    residual: residual(sys, i, &values, &mut derivatives),
                }
            }
            1 => enqueue(&mut queues, i, sys, &values),
            _ => {}
        }
    }
    while let Some(i) = queues.iter_mut().find_map(VecDeque::pop_front) {
        if uses[i] != Use::Pending || unknown[i] != 1 {
            continue;
        }
        let eq = &sys.equations[i];
        let Some(&v) = eq.vars.iter().find(|v| values[v.0 as usize].is_none()) else {
            continue;
        };
        let Some(class) = class_of(model, &sensed, eq, v, mode) else {
            continue;
        };
        let value = solve_for(sys, i, v, &values, &mut derivatives);
        values[v.0 as usize] = Some(value);
        solved_by[v.0 as usize] = Some(i);
        uses[i] = Use::Solves { var: v, class };
        for &j in &var_eqs[v.0 as usize] {
            unknown[j] -= 1;
            if uses[j] != Use::Pending {
                continue;
            }
            match unknown[j] {
                0 => {
                    uses[j] = Use::Redundant {
                        residual: residual(sys, j, &values, &mut derivatives),
                    }
                }
                1 => enqueue(&mut queues, j, sys, &values),
                _ => {}
            }
        }
    }
    Solved {
        values,
        uses,
        solved_by,
    }
}

/// `e` with every unknown replaced by its value.
fn known(pool: &mut Pool, e: ExprId, values: &[Option<ExprId>]) -> ExprId {
    pool.substitute(e, &mut |p, leaf| match leaf {
        Leaf::Var(v) => Some(values[v as usize].unwrap_or_else(|| p.num(f64::NAN))),
        _ => None,
    })
}

fn value_of(pool: &mut Pool, v: VarId, values: &[Option<ExprId>]) -> ExprId {
    values[v.0 as usize].unwrap_or_else(|| pool.num(f64::NAN))
}

type Rule = fn(&mut Pool, Leaf) -> Option<ExprId>;

fn differentiate(pool: &mut Pool, e: ExprId, d: &mut Derivatives<Rule>) -> ExprId {
    d.of(pool, e).unwrap_or_else(|| pool.num(f64::NAN))
}

fn solve_for(
    sys: &mut System,
    i: usize,
    v: VarId,
    values: &[Option<ExprId>],
    d: &mut Derivatives<Rule>,
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
        Relation::Law { rhs, .. } => known(p, rhs, values),
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
    d: &mut Derivatives<Rule>,
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
        Relation::Law { out, rhs } => {
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
