//! Causality: which end of each bond sets its effort, found by orienting the model's equations.
//!
//! Two modes: [`Mode::Integral`] (storage in integral causality, states known: for state
//! equations) and [`Mode::Diagnosis`] (storage in derivative causality, detectors inverted into
//! sources of their measured signal: for ARRs). See [`solve`] for the order of assignment.

pub(crate) mod carried;
pub(crate) mod equations;
mod mode;
pub(crate) mod report;
pub(crate) mod solve;

pub(crate) use mode::Mode;

use equations::{Relation, System, Var, VarId};
use solve::{Solved, Use};

use crate::graph::{BondGraph, BondId, BondKind, NodeId, NodeKind};
use crate::symbolic::ExprId;

/// The causality a storage element took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum StorageCausality {
    /// It holds a state: its co-energy variable comes from the integral of its input.
    Integral,
    /// Its output is the derivative of a function of its input.
    Derivative,
    /// Its equation was not used (unreached part of the graph, or a loop).
    Unassigned,
}

/// A model's equations, oriented for one mode.
pub(crate) struct Causal {
    /// The mode.
    pub mode: Mode,
    /// The equations and their expressions.
    pub system: System,
    /// How each was used.
    pub solved: Solved,
}

/// Orients the equations of `model` for `mode`.
pub(crate) fn assign(model: &BondGraph, mode: Mode) -> Causal {
    let mut system = equations::build(model, mode);
    let solved = solve::solve(model, &mut system, mode);
    Causal {
        mode,
        system,
        solved,
    }
}

/// Orients the equations of `model` for diagnosis with those `drop` accepts left out: the
/// model without some components, whose redundant equations are residuals that a fault of
/// those components cannot reach. The `let`s of `free` are held as unknowns in the sources
/// that scale them (see [`equations::build_freeing`]): a modulation left out is eliminated
/// between its sources instead of losing them all.
pub(crate) fn assign_freeing(
    model: &BondGraph,
    free: &[crate::graph::LetId],
    drop: &dyn Fn(&equations::Equation) -> bool,
) -> Causal {
    assign_in(model, free, None, drop)
}

/// [`assign_freeing`] on the equations of the nodes of `scope` only (increasing), when given.
pub(crate) fn assign_in(
    model: &BondGraph,
    free: &[crate::graph::LetId],
    scope: Option<&[crate::graph::NodeId]>,
    drop: &dyn Fn(&equations::Equation) -> bool,
) -> Causal {
    let mut system = equations::build_in(model, Mode::Diagnosis, free, scope);
    system.equations.retain(|e| !drop(e));
    let solved = solve::solve(model, &mut system, Mode::Diagnosis);
    Causal {
        mode: Mode::Diagnosis,
        system,
        solved,
    }
}

impl Causal {
    /// The value of an unknown, if it was computed.
    pub(crate) fn value(&self, var: Var) -> Option<ExprId> {
        self.system
            .var(var)
            .and_then(|v| self.solved.values[v.index()])
    }

    /// The node that sets the effort of a power bond (the stroke is at the other end).
    pub(crate) fn effort_setter(&self, model: &BondGraph, bond: BondId) -> Option<NodeId> {
        let v = self.system.var(Var::Effort(bond))?;
        let eq = self.solved.solved_by[v.index()]?;
        let owner = self.system.equations[eq].owner;
        let (tail, head) = model.ends(bond);
        // A detector imposes through its junction.
        if owner == tail || owner == head {
            Some(owner)
        } else {
            [tail, head]
                .into_iter()
                .find(|&n| model.node(n).is_junction())
        }
    }

    /// The causality each storage element took: derivative when its equation computed the
    /// rate (the derivative of its energy variable), integral when it computed the co-energy
    /// variable from a state or an integral.
    pub(crate) fn storage(&self, model: &BondGraph) -> Vec<(NodeId, StorageCausality)> {
        let mut out = Vec::new();
        for (i, eq) in self.system.equations.iter().enumerate() {
            let NodeKind::Element(kind, _) = model.node(eq.owner).kind else {
                continue;
            };
            if !kind.is_storage() {
                continue;
            }
            let causality = match (&eq.relation, self.solved.uses[i]) {
                (Relation::Assign { .. }, Use::Solves { .. }) => StorageCausality::Integral,
                (
                    Relation::Storage {
                        derivative,
                        integral,
                        implicit,
                    },
                    Use::Solves { var, .. },
                ) => {
                    let rate = |d: &Option<(VarId, ExprId)>| d.is_some_and(|d| d.0 == var);
                    if rate(derivative) || rate(implicit) {
                        StorageCausality::Derivative
                    } else if integral.is_some_and(|d| d.0 == var) {
                        StorageCausality::Integral
                    } else {
                        StorageCausality::Unassigned
                    }
                }
                // Checked both ways; the residual uses the derivative form when there is one.
                (Relation::Storage { derivative, .. }, Use::Redundant { residual }) => {
                    let root = (self.system.pool.leaves(residual).iter())
                        .any(|l| matches!(l, crate::symbolic::Leaf::Root(..)));
                    if derivative.is_some() || root {
                        StorageCausality::Derivative
                    } else {
                        StorageCausality::Integral
                    }
                }
                _ => StorageCausality::Unassigned,
            };
            out.push((eq.owner, causality));
        }
        out
    }

    /// Unknowns that could not be computed.
    pub(crate) fn unsolved(&self) -> Vec<VarId> {
        (0..self.system.vars.len())
            .filter(|&i| self.solved.values[i].is_none())
            .map(|i| VarId(i as u32))
            .collect()
    }

    /// Equations left over: (equation index, residual).
    pub(crate) fn redundant(&self) -> Vec<(usize, ExprId)> {
        self.solved
            .uses
            .iter()
            .enumerate()
            .filter_map(|(i, u)| match u {
                Use::Redundant { residual } => Some((i, *residual)),
                _ => None,
            })
            .collect()
    }

    /// The bond (or detector) that sets the common variable of a junction.
    pub(crate) fn strong_bond(&self, model: &BondGraph, junction: NodeId) -> Option<Strong> {
        let v = self.system.var(Var::Common(junction))?;
        let eq = &self.system.equations[self.solved.solved_by[v.index()]?];
        match (&eq.relation, &model.node(eq.owner).kind) {
            (_, NodeKind::Detector(_)) => Some(Strong::Detector(eq.owner)),
            (Relation::Scale { a, .. }, _) => match self.system.vars[a.index()] {
                Var::Effort(b) | Var::Flow(b) if model.bond(b).kind == BondKind::Power => {
                    Some(Strong::Bond(b))
                }
                _ => None,
            },
            _ => None,
        }
    }
}

/// What sets a junction's common variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Strong {
    /// A power bond.
    Bond(BondId),
    /// An inverted detector.
    Detector(NodeId),
}
