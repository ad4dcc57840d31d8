//! Simulated residuals: a detector's reading against the output of a copy of the model that
//! the inputs drive, `r = y − ŷ(x̂)` with `dx̂/dt = f(x̂, u)` the state equations.
//!
//! Such a residual reads one detector and no other: where a modulation reads another
//! detector (the bench's backlash `w`, computed from both encoders), the copy reads the
//! output that detector measures. So on the bench the residual of `y1` does not show `y2`,
//! which no ARR can do without solving the link's law `K z + w(z)` for the twist: the copy
//! integrates the twist instead. It holds from a known initial state (the model's, at rest)
//! and on a plant whose unmeasured motion settles, as every `int(..)` an ARR reads does; the
//! derivation follows the integral causality's equations, so it is linear in their size.

use std::collections::{BTreeSet, HashMap};

use super::component::{Component, ComponentKind};
use super::fsm::RowIndex;
use crate::causality::equations::Var;
use crate::causality::Causal;
use crate::graph::{BondGraph, LetId, NodeId, ParamId};
use crate::state_space::StateSpace;
use crate::symbolic::{ExprId, Leaf};

/// One detector's simulated residual.
#[derive(Clone, Debug)]
pub(crate) struct Simulated {
    /// The detector.
    pub sensor: NodeId,
    /// Every node whose equation the output was computed from, through the states it reads.
    pub nodes: BTreeSet<NodeId>,
    /// Every `let` those equations use.
    pub lets: BTreeSet<LetId>,
    /// The parameters the output and the right-hand sides of the states it reads hold.
    pub parameters: BTreeSet<ParamId>,
    /// The detectors whose measurements drive the copy (a partial copy's; none for a copy
    /// of the whole model).
    pub imposed: Vec<NodeId>,
    /// The elements the imposed measurements' outputs are computed from, but for the
    /// storage whose state they stand for: shown where a parameter of theirs survives in
    /// the copy (a source or a junction between, which has none, shows through the rest).
    pub through: BTreeSet<NodeId>,
}

/// The simulated residual of each detector, when the state equations are explicit, complete
/// and read the inputs' values only (none otherwise: a copy of the model could not be run on
/// recorded samples).
pub(crate) fn simulated(
    model: &BondGraph,
    integral: &Causal,
    space: &StateSpace,
) -> Vec<Simulated> {
    // A copy that needs an input's derivatives would differentiate recorded samples: the
    // residuals that do so are the ARRs' business.
    let differentiates = space.states.iter().any(|s| {
        (space.pool.leaves(s.rhs).iter()).any(|l| matches!(l, Leaf::Input(_, n) if *n > 0))
    });
    if !space.problems.is_empty() || !space.implicit.is_empty() || differentiates {
        return Vec::new();
    }
    let rate = rates(integral);
    space
        .outputs
        .iter()
        .filter_map(|&(sensor, output)| {
            let start = computed_at(model, integral, sensor)?;
            let (nodes, lets) = cone(model, integral, Some(&rate), start, &BTreeSet::new());
            Some(Simulated {
                sensor,
                nodes,
                lets,
                parameters: parameters(space, output),
                imposed: Vec::new(),
                through: BTreeSet::new(),
            })
        })
        .collect()
}

/// Each partial copy of the model (see [`super::partial`]) as a simulated residual: the
/// nodes and `let`s its output is computed from stop at what the imposed detectors measure.
pub(crate) fn partial(
    model: &BondGraph,
    integral: &Causal,
    space: &StateSpace,
) -> Vec<(Simulated, super::partial::PartialCopy)> {
    if simulated(model, integral, space).is_empty() {
        return Vec::new();
    }
    let rate = rates(integral);
    super::partial::partial_copies(space)
        .into_iter()
        .filter_map(|copy| {
            let start = computed_at(model, integral, copy.own)?;
            let imposed: BTreeSet<NodeId> = copy.imposed.iter().copied().collect();
            let (nodes, mut lets) = cone(model, integral, Some(&rate), start, &imposed);
            let mut through = BTreeSet::new();
            // An imposed measurement stands for the state it is affine in, solved from its
            // output's equation: what that equation is computed from enters the copy too
            // (on a resistive loop, the source current measured through R1 gives the
            // capacitor's charge, and R1 moves the capacitor voltage's copy), though not
            // the state's rate, which the copy no longer integrates.
            for &d in &copy.imposed {
                let Some(at) = computed_at(model, integral, d) else {
                    continue;
                };
                let (n, l) = cone(model, integral, None, at, &BTreeSet::new());
                through.extend(n.into_iter().filter(|&n| between(model, n)));
                lets.extend(l);
            }
            let output = copy.space.outputs.first()?.1;
            let found = Simulated {
                sensor: copy.own,
                nodes,
                lets,
                parameters: parameters(&copy.space, output),
                imposed: copy.imposed.clone(),
                through,
            };
            Some((found, copy))
        })
        .collect()
}

/// Whether `node` can stand between a measured quantity and the state it is affine in: a
/// resistor or a converter. A storage's state is what the measurement stands for, and a
/// source acts on the state's rate, which the copy no longer integrates (the bench's
/// load-side backlash torque on its load speed).
fn between(model: &BondGraph, node: NodeId) -> bool {
    use crate::graph::model::{ElementKind, NodeKind};
    matches!(
        model.node(node).kind,
        NodeKind::Element(
            ElementKind::R
                | ElementKind::TF
                | ElementKind::GY
                | ElementKind::MTF
                | ElementKind::MGY,
            _
        )
    )
}

/// The equation that solves each state's rate, by its storage element.
fn rates(integral: &Causal) -> HashMap<NodeId, usize> {
    (integral.system.states.iter())
        .filter_map(|s| Some((s.element, integral.solved.solved_by[s.rate.index()]?)))
        .collect()
}

/// The equation that computes what `sensor` measures (its junction's common variable).
fn computed_at(model: &BondGraph, integral: &Causal, sensor: NodeId) -> Option<usize> {
    let junction = model.detector_junction(sensor)?;
    let v = integral.system.var(Var::Common(junction))?;
    integral.solved.solved_by[v.index()]
}

/// The nodes and `let`s of every equation `start` depends on: through the unknowns it reads,
/// the rate of each state it reads (where `rate` is given), and the output of each detector
/// a `let` of it reads; not through what a detector of `imposed` measures, which is read
/// from it.
fn cone(
    model: &BondGraph,
    integral: &Causal,
    rate: Option<&HashMap<NodeId, usize>>,
    start: usize,
    imposed: &BTreeSet<NodeId>,
) -> (BTreeSet<NodeId>, BTreeSet<LetId>) {
    let eqs = &integral.system.equations;
    let measured: BTreeSet<usize> = (imposed.iter())
        .filter_map(|&d| model.detector_junction(d))
        .filter_map(|j| integral.system.var(Var::Common(j)))
        .map(|v| v.index())
        .collect();
    let (mut nodes, mut lets) = (BTreeSet::new(), BTreeSet::new());
    let mut seen = BTreeSet::new();
    let mut stack = vec![start];
    while let Some(i) = stack.pop() {
        if !seen.insert(i) {
            continue;
        }
        let eq = &eqs[i];
        nodes.insert(eq.owner);
        lets.extend(eq.lets.iter().copied());
        stack.extend(
            (eq.vars.iter())
                .filter(|v| !measured.contains(&v.index()))
                .filter_map(|v| integral.solved.solved_by[v.index()]),
        );
        stack.extend(rate.and_then(|r| r.get(&eq.owner)).copied());
        for s in super::isolability::sensors_read(&integral.system, eq) {
            if !imposed.contains(&s) {
                stack.extend(computed_at(model, integral, s));
            }
        }
    }
    (nodes, lets)
}

/// The parameters `output` holds, with those of the right-hand sides of the states it reads,
/// directly or through other states.
fn parameters(space: &StateSpace, output: ExprId) -> BTreeSet<ParamId> {
    let read = super::partial::read_from(&space.pool, &space.states, output);
    let rates = (space.states.iter().zip(read))
        .filter(|(_, read)| *read)
        .map(|(s, _)| s.rhs);
    (std::iter::once(output).chain(rates))
        .flat_map(|e| space.pool.leaves(e))
        .filter_map(|leaf| match leaf {
            Leaf::Param(p) => Some(p),
            _ => None,
        })
        .collect()
}

/// The rows of `components` a simulated residual shows, increasing: the elements and `let`s
/// its output was computed from whose parameters it still holds, and its own detector.
pub(crate) fn rows(s: &Simulated, components: &[Component], index: &RowIndex) -> Vec<usize> {
    let survives = |c: &Component| {
        c.parameters.is_empty() || c.parameters.iter().any(|p| s.parameters.contains(p))
    };
    let mut rows: BTreeSet<usize> = BTreeSet::new();
    for n in &s.nodes {
        if let Some(r) = index.node(*n) {
            if matches!(components[r].kind, ComponentKind::Element(_)) {
                rows.insert(r);
            }
        }
    }
    for n in &s.through {
        if let Some(r) = index.node(*n) {
            let c = &components[r];
            let holds = c.parameters.iter().any(|p| s.parameters.contains(p));
            if matches!(c.kind, ComponentKind::Element(_)) && holds {
                rows.insert(r);
            }
        }
    }
    rows.extend(s.lets.iter().filter_map(|l| index.modulation(*l)));
    rows.extend(index.node(s.sensor));
    rows.extend(s.imposed.iter().filter_map(|&d| index.node(d)));
    rows.into_iter()
        .filter(|&r| survives(&components[r]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::causality::{assign, Mode};
    use crate::fdi::components;
    use crate::state_space::state_space_of;

    /// The rows each residual `found` builds for `text` shows, by component name.
    fn shown_by(
        text: &str,
        found: impl Fn(&BondGraph, &Causal, &StateSpace) -> Vec<Simulated>,
    ) -> Vec<(String, Vec<String>)> {
        let (model, diagnostics) = crate::graph::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let integral = assign(&model, Mode::Integral);
        let space = state_space_of(&model, &integral);
        let components = components(&model);
        let index = RowIndex::new(&components);
        found(&model, &integral, &space)
            .iter()
            .map(|s| {
                let names = rows(s, &components, &index)
                    .into_iter()
                    .map(|r| components[r].name.clone())
                    .collect();
                (model.node(s.sensor).name.clone(), names)
            })
            .collect()
    }

    /// The rows each detector's simulated residual shows, by component name.
    fn shown(text: &str) -> Vec<(String, Vec<String>)> {
        shown_by(text, simulated)
    }

    /// The rows each partial copy of `text` shows, by component name.
    fn shown_partial(text: &str) -> Vec<(String, Vec<String>)> {
        shown_by(text, |m, i, s| {
            partial(m, i, s).into_iter().map(|p| p.0).collect()
        })
    }

    /// On the bench, each encoder's simulated residual shows every element, the backlash and
    /// that encoder, and not the other encoder, which the backlash reads.
    #[test]
    fn each_encoder_of_the_bench_is_simulated_without_the_other() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/backlash_bench.bg"
        ))
        .expect("the bench model");
        let every = [
            "U", "Rm", "Lm", "motor", "Jm", "fm", "Wm", "link", "gear", "Jl", "fl", "Wl", "w",
        ];
        let expect = |own: &str| -> Vec<String> {
            every
                .iter()
                .copied()
                .chain([own])
                .map(String::from)
                .collect()
        };
        assert_eq!(
            shown(&text),
            vec![
                ("y1".to_string(), expect("y1")),
                ("y2".to_string(), expect("y2"))
            ]
        );
    }

    /// On the bench, the motor's partial copy shows the motor's side, the link, the gear and
    /// the backlash, and both encoders (the load's drives it), not the load; the load's copy
    /// the load's side, the link, the gear and the backlash, and both encoders.
    #[test]
    fn each_encoder_of_the_bench_is_copied_with_its_side_only() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/backlash_bench.bg"
        ))
        .expect("the bench model");
        let names = |n: &[&str]| -> Vec<String> { n.iter().map(|s| s.to_string()).collect() };
        assert_eq!(
            shown_partial(&text),
            vec![
                (
                    "y1".to_string(),
                    names(&[
                        "U", "Rm", "Lm", "motor", "Jm", "fm", "Wm", "link", "gear", "w", "y1", "y2"
                    ])
                ),
                (
                    "y2".to_string(),
                    names(&["link", "gear", "Jl", "fl", "Wl", "w", "y1", "y2"])
                ),
            ]
        );
    }

    /// Two tanks in series, both levels measured: the first level depends on the second
    /// tank through the valve between them, so each simulated residual shows the whole chain,
    /// with its own detector and not the other.
    #[test]
    fn a_simulated_output_shows_every_element_that_drives_it_and_one_detector() {
        let text = "model t\nparam A1 = 1\nparam A2 = 2\nparam R1 = 3\nparam R2 = 4\ninput q\n\
                    Sf in = q\nC tank1 = A1\nR out1 = R1\nC tank2 = A2\nR out2 = R2\n\
                    De h1 on a\nDe h2 on b\nin -> 0:a -> tank1\na -> 1:p -> out1\n\
                    p -> 0:b -> tank2, out2\n";
        let chain = |own: &str| -> Vec<String> {
            ["in", "tank1", "out1", "tank2", "out2", own]
                .map(String::from)
                .to_vec()
        };
        assert_eq!(
            shown(text),
            vec![
                ("h1".to_string(), chain("h1")),
                ("h2".to_string(), chain("h2"))
            ]
        );
    }
}
