//! Analytical redundancy relations: the equations left over once the model, in derivative
//! causality with inverted detectors, has computed every unknown from known signals.

use std::collections::BTreeSet;

use super::auxiliary::{self, Auxiliary};
use super::eliminate::eliminate;
use super::roots::RootLaw;
use crate::causality::equations::{Equation, VarId};
use crate::causality::{assign, assign_freeing, assign_in, report, Causal, Mode};
use crate::diagnostic::{Code, Diagnostic, Severity};
use crate::graph::{BondGraph, LetId, NodeId, NodeKind};
use crate::symbolic::{ExprId, Leaf};

/// One ARR: `residual = 0` while the machine is healthy.
#[derive(Clone, Debug)]
pub(crate) struct Arr {
    /// `ARR1`, `ARR2`…
    pub name: String,
    /// The node whose equation became redundant.
    pub origin: NodeId,
    /// The junction the ARR is labelled with: its detector's, when that junction's equation
    /// is part of it; else the origin, or the junction an element is bonded to.
    pub junction: NodeId,
    /// The detector the ARR is attributed to.
    pub sensor: Option<NodeId>,
    /// The residual, over parameters, inputs, measured signals and auxiliary signals.
    pub residual: ExprId,
    /// The residual with its auxiliary signals put back (a DAG, never printed): what its
    /// dependences and the signals it reads are judged on.
    pub expanded: ExprId,
    /// Every node whose equation the residual was derived from.
    pub nodes: BTreeSet<NodeId>,
    /// Every `let` those equations use.
    pub lets: BTreeSet<LetId>,
}

/// The ARRs of a model, with the oriented equations they came from.
pub(crate) struct Diagnosis {
    /// The equations in diagnosis causality.
    pub causal: Causal,
    /// The ARRs, in the order of the nodes they come from.
    pub arrs: Vec<Arr>,
    /// The auxiliary signals the ARRs read, with the derivatives they read.
    pub auxiliaries: Vec<Auxiliary>,
    /// The laws of the roots ([`Leaf::Root`]) the ARRs read, by index; an ARR reads a
    /// root's value only, its derivatives put back in terms of it.
    pub roots: Vec<RootLaw>,
    /// Problems met: unknowns that could not be computed, missing ARRs.
    pub problems: Vec<Diagnostic>,
}

/// Derives the ARRs of `model`.
pub(crate) fn diagnose(model: &BondGraph) -> Diagnosis {
    from_causal(model, assign(model, Mode::Diagnosis), true)
}

/// Derives the ARRs of `model` with the `let`s of `free` held as unknowns where sources scale
/// them, and the equations `drop` accepts left out.
pub(super) fn diagnose_freeing(
    model: &BondGraph,
    free: &[LetId],
    drop: &dyn Fn(&Equation) -> bool,
) -> Diagnosis {
    from_causal(model, assign_freeing(model, free, drop), true)
}

/// The ARRs of the equations of the nodes of `scope` (increasing), with the `let`s of `free`
/// held as unknowns and those `drop` accepts left out: a part of a large model, in time
/// proportional to the part. What keeps the part's detectors from ARRs is not reported.
pub(super) fn diagnose_in(
    model: &BondGraph,
    free: &[LetId],
    scope: &[NodeId],
    drop: &dyn Fn(&Equation) -> bool,
) -> Diagnosis {
    from_causal(model, assign_in(model, free, Some(scope), drop), false)
}

/// The ARRs of equations in diagnosis causality.
fn from_causal(model: &BondGraph, mut causal: Causal, with_problems: bool) -> Diagnosis {
    let redundant = causal.redundant();
    let mut eliminated = eliminate(&mut causal.system.pool, &causal.solved.torn, &redundant);
    if with_problems {
        super::basis::sparsen(&mut causal.system.pool, model, &mut eliminated.relations);
    }
    let pool = &mut causal.system.pool;
    let roots: Vec<ExprId> = eliminated.relations.iter().map(|r| r.expr).collect();
    let mut auxiliaries = eliminated.auxiliaries;
    let expanded = match auxiliary::differentiate(pool, &mut auxiliaries, &roots) {
        Some(()) => auxiliary::expand(pool, &auxiliaries, &roots),
        None => roots,
    };
    // The roots' laws, with each derivative the relations read written in terms of the
    // roots; a relation whose roots cannot be written so is not one a generator can evaluate.
    let laws = super::roots::explicit(pool, &causal.solved.roots)
        .and_then(|mut x| x.laws_for(pool, &expanded));
    let keep: Vec<bool> = (expanded.iter())
        .map(|&e| laws.is_some() || !holds_root(pool, e))
        .collect();
    let mut kept = keep.iter();
    eliminated
        .relations
        .retain(|_| kept.next().copied().unwrap_or(false));
    let expanded: Vec<ExprId> = (expanded.into_iter().zip(&keep))
        .filter_map(|(e, &k)| k.then_some(e))
        .collect();
    let roots = laws.unwrap_or_default();
    let torn: BTreeSet<VarId> = causal.solved.torn.iter().map(|t| t.var).collect();
    let mut arrs: Vec<Arr> = eliminated
        .relations
        .into_iter()
        .zip(expanded)
        .map(|(relation, expanded)| {
            let (mut nodes, mut lets) = (BTreeSet::new(), BTreeSet::new());
            for &eq in &relation.equations {
                cone(&causal, &torn, eq, &mut nodes, &mut lets);
            }
            // A root's law was put over known signals whole, through any torn unknown.
            for leaf in causal.system.pool.leaves(expanded) {
                if let Some(root) = leaf_root(&causal, leaf) {
                    cone(
                        &causal,
                        &BTreeSet::new(),
                        root.equation,
                        &mut nodes,
                        &mut lets,
                    );
                }
            }
            let origin = causal.system.equations[relation.origin].owner;
            Arr {
                name: String::new(),
                origin,
                junction: junction_of(model, origin),
                sensor: None,
                residual: relation.expr,
                expanded,
                nodes,
                lets,
            }
        })
        .collect();
    arrs.sort_by_key(|a| a.origin);
    attribute_sensors(model, &causal, &mut arrs);
    for (i, arr) in arrs.iter_mut().enumerate() {
        arr.name = format!("ARR{}", i + 1);
    }
    let mut problems = if with_problems {
        problems(model, &causal, &arrs)
    } else {
        Vec::new()
    };
    let why = [
        (eliminated.non_smooth, "is known only through a law with sign() (or abs, min, max) that the relations would differentiate past its jumps: d/dt sign(x) is an impulse where x crosses zero, not 0, so they are not reported"),
        (eliminated.problems, "enters the relations that hold it nonlinearly, once its value is no longer explicit: they are not reported"),
    ];
    for (vars, reason) in why.into_iter().filter(|_| with_problems) {
        for u in vars {
            let var = causal.system.vars[u.index()];
            problems.push(report::at_nodes(
                model,
                Severity::Warning,
                Code::NoArr,
                &var.nodes(model),
                format!("{} {reason}", var.describe(model)),
            ));
        }
    }
    Diagnosis {
        causal,
        arrs,
        auxiliaries,
        roots,
        problems,
    }
}

/// The root a leaf is, if it is one.
fn leaf_root(causal: &Causal, leaf: Leaf) -> Option<&crate::causality::solve::Root> {
    match leaf {
        Leaf::Root(k, _) => causal.solved.roots.get(k.index()),
        _ => None,
    }
}

/// Whether `e` reads a root.
fn holds_root(pool: &crate::symbolic::Pool, e: ExprId) -> bool {
    pool.leaves(e).iter().any(|l| matches!(l, Leaf::Root(..)))
}

/// `node` if it is a junction, else the first junction it is bonded to.
fn junction_of(model: &BondGraph, node: NodeId) -> NodeId {
    let is_junction = |n: NodeId| model.node(n).is_junction();
    if is_junction(node) {
        return node;
    }
    let ends = |b: crate::graph::BondId| {
        let (t, h) = model.ends(b);
        if t == node {
            h
        } else {
            t
        }
    };
    model
        .bonds_at(node, petgraph::Direction::Incoming)
        .into_iter()
        .chain(model.bonds_at(node, petgraph::Direction::Outgoing))
        .map(ends)
        .find(|&n| is_junction(n))
        .unwrap_or(node)
}

/// Adds the nodes and `let`s of every equation that equation `start` depends on, up to the
/// torn unknowns: what computed those belongs to the relations they were eliminated with.
fn cone(
    causal: &Causal,
    torn: &BTreeSet<VarId>,
    start: usize,
    nodes: &mut BTreeSet<NodeId>,
    lets: &mut BTreeSet<LetId>,
) {
    let eqs = &causal.system.equations;
    let mut seen = BTreeSet::new();
    let mut stack = vec![start];
    while let Some(i) = stack.pop() {
        if !seen.insert(i) {
            continue;
        }
        nodes.insert(eqs[i].owner);
        lets.extend(eqs[i].lets.iter().copied());
        for v in eqs[i].vars.iter().filter(|v| !torn.contains(v)) {
            if let Some(j) = causal.solved.solved_by[v.index()] {
                if j != i {
                    stack.push(j);
                }
            }
        }
    }
}

/// Each ARR gets one detector it uses, the first in declaration order not already taken.
fn attribute_sensors(model: &BondGraph, causal: &Causal, arrs: &mut [Arr]) {
    let mut taken = BTreeSet::new();
    for arr in arrs.iter_mut() {
        let mut used: BTreeSet<NodeId> = BTreeSet::new();
        for leaf in causal.system.pool.leaves(arr.expanded) {
            if let Leaf::Sensor(s, _) = leaf {
                used.insert(s);
            }
        }
        used.extend(
            arr.nodes
                .iter()
                .filter(|n| matches!(model.node(**n).kind, NodeKind::Detector(_))),
        );
        // The detector on the ARR's own junction first, then any other it uses.
        let own = used
            .iter()
            .find(|s| model.detector_junction(**s) == Some(arr.junction));
        arr.sensor = own
            .filter(|s| !taken.contains(*s))
            .or_else(|| used.iter().find(|s| !taken.contains(*s)))
            .or_else(|| used.iter().next())
            .copied();
        if let Some(s) = arr.sensor {
            taken.insert(s);
            // A reader finds an ARR by its detector: it is labelled with the detector's
            // junction when that junction's equation is part of it, not with the junction
            // whose equation happened to be combined last.
            if let Some(j) = model.detector_junction(s).filter(|j| arr.nodes.contains(j)) {
                arr.junction = j;
            }
        }
    }
}

/// What keeps some detector from yielding an ARR: the unknowns no detector computes, then
/// each detector left without one.
fn problems(model: &BondGraph, causal: &Causal, arrs: &[Arr]) -> Vec<Diagnostic> {
    let mut out = report::refusals(model, causal);
    out.extend(report::unsolved(model, causal));
    let attributed: BTreeSet<NodeId> = arrs.iter().filter_map(|a| a.sensor).collect();
    for d in model.nodes() {
        if matches!(model.node(d).kind, NodeKind::Detector(_)) && !attributed.contains(&d) {
            out.push(
                report::at_nodes(
                    model,
                    Severity::Warning,
                    Code::NoArr,
                    &[d],
                    format!(
                        "the detector `{}` yields no ARR of its own: its junction's equation is not redundant with the others",
                        model.node(d).name
                    ),
                )
                .with_help("another detector may measure the same part of the model; `bgc causality` shows what sets each junction"),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{mass_spring_chain, mass_spring_chain_varied};

    /// The highest derivative each ARR reads, with its auxiliary signals put back, after
    /// checking that it reads its own detector's neighbours only.
    fn orders(text: &str) -> Vec<u32> {
        let (model, diagnostics) = crate::graph::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let d = diagnose(&model);
        assert!(d.problems.is_empty(), "{:?}", d.problems);
        assert_eq!(d.arrs.len(), model.counts().detectors);
        let index = |s: NodeId| {
            let name = &model.node(s).name;
            name[1..].parse::<usize>().expect("detectors are y<stage>") / 5
        };
        let mut out = Vec::new();
        for arr in &d.arrs {
            let own = index(arr.sensor.expect("attributed"));
            let mut top = 0;
            for leaf in d.causal.system.pool.leaves(arr.expanded) {
                if let Leaf::Sensor(s, n) = leaf {
                    let k = index(s);
                    assert!(
                        k + 1 >= own && k <= own + 1,
                        "{} (at detector {own}) reads detector {k}",
                        arr.name
                    );
                    top = top.max(n);
                }
            }
            out.push(top);
        }
        out
    }

    /// In a chain measured every 5th mass, each ARR relates a detector to its neighbours
    /// only, with derivatives of bounded order, however long the chain: the forces between
    /// measured masses are eliminated locally, not carried from one end. With parameters of
    /// their own per stage, the order is the same at 21 and 41 stages, ARR by ARR from each
    /// end.
    #[test]
    fn the_arrs_of_a_long_chain_are_local_and_of_bounded_order() {
        let shared = orders(&mass_spring_chain(41, 5));
        assert!(shared.iter().all(|&n| n <= 20), "{shared:?}");
        let short = orders(&mass_spring_chain_varied(21, 5));
        let long = orders(&mass_spring_chain_varied(41, 5));
        let k = short.len() / 2;
        assert_eq!(short[..k], long[..k], "from the input end");
        assert_eq!(
            short[k..],
            long[long.len() - (short.len() - k)..],
            "from the far end"
        );
        let interior = long[k];
        assert!(
            long[k..long.len() - 2].iter().all(|&n| n == interior),
            "{long:?}"
        );
    }
}
