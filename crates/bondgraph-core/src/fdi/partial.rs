//! Partial copies: a detector's reading against a copy of the part of the model that the
//! other detectors' measured signals drive, `r = y − ŷ(x̂)` with `dx̂/dt = f(x̂, u, y_other)`.
//!
//! A simulated residual (see `simulated`) runs the whole model from the inputs: every state
//! it holds integrates the model's error and the plant's drift, and its output depends on
//! every element. Where another detector measures a state (an encoder the speed of an
//! inertia: `y2 = p_Jl/Js`), the copy takes that state from the measurement instead
//! (`p_Jl = Js·y2`) and no longer integrates it: the copy of the bench's motor side is its
//! current, its speed and the twist, driven by the voltage and the load's measured speed.
//! What remains is what those generators of faultdiagnosistoolbox integrate: a low-pass
//! filter on the noise by the model's own dynamics, reading no derivative.
//!
//! A detector is imposed where its output is affine in one state, with a coefficient that
//! holds no other state (a sensor's gain, bias and drift stay in it): the state is then that
//! output solved for it. Its own state equation is dropped; the states the copy's output no
//! longer reads, through the right-hand sides, are dropped too.

use std::collections::BTreeSet;

use crate::graph::NodeId;
use crate::state_space::{self, StateEquation, StateSpace};
use crate::symbolic::invert::linear_root_of;
use crate::symbolic::{ExprId, Leaf, Pool, Simplifier, StateIx};

/// The state equations of the copy `own`'s reading is compared with.
pub(crate) struct PartialCopy {
    /// The detector whose reading the copy's output is compared with.
    pub own: NodeId,
    /// The detectors whose measured signals the copy reads instead of integrating the
    /// states they measure, in the model's order.
    pub imposed: Vec<NodeId>,
    /// The copy: its states, and one output, `own`'s.
    pub space: StateSpace,
}

/// The partial copy for each detector of `space` that at least one other detector's
/// measurement drives; none where the state equations cannot be run on recorded samples
/// (see `simulated::simulated`).
pub(crate) fn partial_copies(space: &StateSpace) -> Vec<PartialCopy> {
    if !space.problems.is_empty() || !space.implicit.is_empty() {
        return Vec::new();
    }
    (space.outputs.iter())
        .filter_map(|&(own, _)| partial_copy(space, own))
        .collect()
}

/// The partial copy for `own` (see the module's doc), if another detector is imposed.
fn partial_copy(space: &StateSpace, own: NodeId) -> Option<PartialCopy> {
    let mut pool = space.pool.clone();
    let mut imposed = Vec::new();
    let mut taken: Vec<(StateIx, ExprId)> = Vec::new();
    for &(other, output) in space.outputs.iter().filter(|o| o.0 != own) {
        let Some(state) = measured_state(&mut pool, output, other) else {
            continue;
        };
        if taken.iter().any(|(s, _)| *s == state.0) {
            continue;
        }
        imposed.push(other);
        taken.push(state);
    }
    if imposed.is_empty() {
        return None;
    }
    let mut states = space.states.clone();
    let mut output = space.outputs.iter().find(|o| o.0 == own)?.1;
    let put = |pool: &mut Pool, e: ExprId| {
        let e = pool.substitute(e, &mut |_, leaf| match leaf {
            Leaf::State(k) => taken.iter().find(|(s, _)| *s == k).map(|(_, v)| *v),
            _ => None,
        });
        Simplifier::default().simplify(pool, e)
    };
    for s in states.iter_mut() {
        s.rhs = put(&mut pool, s.rhs);
    }
    output = put(&mut pool, output);
    let kept = read_from(&pool, &states, output);
    let mut outputs = vec![(own, output)];
    state_space::renumber(&mut pool, &mut states, &mut outputs, &mut [], &kept);
    let states: Vec<StateEquation> = (states.into_iter().zip(&kept))
        .filter(|(_, &k)| k)
        .map(|(s, _)| s)
        .collect();
    Some(PartialCopy {
        own,
        imposed,
        space: StateSpace {
            pool,
            states,
            outputs,
            implicit: Vec::new(),
            problems: Vec::new(),
        },
    })
}

/// The state `output` (detector `sensor`'s) measures and its value from the measurement,
/// where `output` reads one state, affinely.
fn measured_state(pool: &mut Pool, output: ExprId, sensor: NodeId) -> Option<(StateIx, ExprId)> {
    let leaves = pool.leaves(output);
    let mut states = leaves.iter().filter_map(|l| match l {
        Leaf::State(k) => Some(*k),
        _ => None,
    });
    let state = states.next()?;
    let unknown = |l: &Leaf| matches!(l, Leaf::Var(_) | Leaf::Root(..) | Leaf::Tear(..));
    if states.next().is_some() || leaves.iter().any(unknown) {
        return None;
    }
    let y = pool.leaf(Leaf::Sensor(sensor, 0));
    let residual = pool.sub(output, y);
    let value = linear_root_of(pool, residual, Leaf::State(state))?;
    // The value must not read the state again (an affine map solved, not a fixed point).
    let again = pool.leaves(value).contains(&Leaf::State(state));
    (!again).then_some((state, value))
}

/// Which states `output` reads, directly or through the right-hand sides of those it reads.
pub(super) fn read_from(pool: &Pool, states: &[StateEquation], output: ExprId) -> Vec<bool> {
    let mut read = BTreeSet::new();
    let mut stack = vec![output];
    while let Some(e) = stack.pop() {
        for leaf in pool.leaves(e) {
            if let Leaf::State(k) = leaf {
                if read.insert(k.index()) {
                    stack.extend(states.get(k.index()).map(|s| s.rhs));
                }
            }
        }
    }
    (0..states.len()).map(|k| read.contains(&k)).collect()
}

#[cfg(test)]
mod tests_support {
    use super::*;
    use crate::causality::{assign, Mode};
    use crate::graph::BondGraph;
    use crate::state_space::state_space_of;
    use crate::symbolic::Printer;

    /// `e` as text, states by `names`, parameters and detectors by the model's names.
    fn shown(model: &BondGraph, pool: &Pool, e: ExprId, names: &[String]) -> String {
        Printer::new(pool, |l: Leaf| match l {
            Leaf::State(k) => names[k.index()].clone(),
            Leaf::Param(p) => model.params[p.index()].name.clone(),
            Leaf::Sensor(n, 0) => model.node(n).name.clone(),
            other => format!("{other:?}"),
        })
        .text(e)
    }

    /// Each partial copy of `text`: its detector, the detectors imposed, and its state
    /// equations and output as printed.
    pub(super) fn copies(text: &str) -> Vec<(String, Vec<String>, Vec<String>)> {
        let (model, diagnostics) = crate::graph::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let integral = assign(&model, Mode::Integral);
        let space = state_space_of(&model, &integral);
        let name = |n: NodeId| model.node(n).name.clone();
        partial_copies(&space)
            .into_iter()
            .map(|c| {
                let names: Vec<String> = c.space.states.iter().map(|s| s.name.clone()).collect();
                let mut lines: Vec<String> = (c.space.states.iter())
                    .map(|s| {
                        let rhs = shown(&model, &c.space.pool, s.rhs, &names);
                        format!("der({}) = {rhs}", s.name)
                    })
                    .collect();
                let out = shown(&model, &c.space.pool, c.space.outputs[0].1, &names);
                lines.push(format!("{} = {out}", name(c.own)));
                (
                    name(c.own),
                    c.imposed.iter().map(|&n| name(n)).collect(),
                    lines,
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::copies;

    /// Two tanks in series, both levels measured: the first level's copy takes the second
    /// level from its sensor, and keeps the first tank only; the second's takes the first
    /// level from its sensor, and keeps the second tank only.
    #[test]
    fn each_level_of_two_tanks_is_copied_with_the_other_imposed() {
        let text = "model t\nparam A1 = 1\nparam A2 = 2\nparam R1 = 3\nparam R2 = 4\ninput q\n\
                    Sf in = q\nC tank1 = A1\nR out1 = R1\nC tank2 = A2\nR out2 = R2\n\
                    De h1 on a\nDe h2 on b\nin -> 0:a -> tank1\na -> 1:p -> out1\n\
                    p -> 0:b -> tank2, out2\n";
        let found = copies(text);
        assert_eq!(found.len(), 2, "{found:?}");
        assert_eq!(found[0].0, "h1");
        assert_eq!(found[0].1, ["h2"]);
        assert_eq!(found[0].2.len(), 2, "{found:?}");
        assert!(found[0].2[0].starts_with("der(q_tank1) = "), "{found:?}");
        assert!(found[0].2[0].contains("h2"), "{found:?}");
        assert_eq!(found[1].0, "h2");
        assert_eq!(found[1].1, ["h1"]);
        assert!(found[1].2[0].starts_with("der(q_tank2) = "), "{found:?}");
        assert!(found[1].2[0].contains("h1"), "{found:?}");
    }
}

#[cfg(test)]
mod bench {
    use super::tests_support::copies;

    /// The bench: the motor's copy holds the current, the motor's speed and the twist, the
    /// load's measured speed driving the twist; the load's holds the twist and the load's
    /// speed, the motor's measured speed driving the twist.
    #[test]
    fn the_bench_is_copied_side_by_side() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/backlash_bench.bg"
        ))
        .expect("the bench model");
        let found = copies(&text);
        let heads = |lines: &[String]| -> Vec<String> {
            lines
                .iter()
                .map(|l| l.split(" = ").next().unwrap_or("").to_string())
                .collect()
        };
        assert_eq!(found.len(), 2, "{found:?}");
        let (own, imposed, motor) = &found[0];
        assert_eq!(
            (own.as_str(), imposed.as_slice()),
            ("y1", &["y2".to_string()][..])
        );
        assert_eq!(
            heads(motor),
            ["der(p_Lm)", "der(p_Jm)", "der(q_link)", "y1"]
        );
        assert_eq!(motor[2], "der(q_link) = -(N * y2) + p_Jm / Je");
        assert_eq!(motor[3], "y1 = p_Jm / Je");
        // The dead zone's argument: the copy's own motor angle, the load's measured one.
        assert!(motor[1].contains("N * int(y2)") && motor[1].contains("int(p_Jm) / Je"));
        let (own, imposed, load) = &found[1];
        assert_eq!(
            (own.as_str(), imposed.as_slice()),
            ("y2", &["y1".to_string()][..])
        );
        assert_eq!(heads(load), ["der(q_link)", "der(p_Jl)", "y2"]);
        assert_eq!(load[0], "der(q_link) = y1 - N * p_Jl / Js");
        assert!(load[1].contains("int(y1)") && load[1].contains("p_Jl * fs / Js"));
        assert!(
            !load[1].contains("Re") && !load[1].contains("Je"),
            "{load:?}"
        );
    }
}
