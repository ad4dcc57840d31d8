//! Sensor placement: the fewest detectors to add (an effort detector on a 0-junction, a
//! flow detector on a 1-junction) so that given components become detectable, or as
//! isolable as detectors can make them, judged structurally (see `isolability.rs`).
//!
//! "As isolable as they can be" is what measuring every junction would give: two components
//! on one junction's balance alone (a spring and its damper in parallel) stay together
//! whatever is measured. The search tries every set of one, then two… unmeasured
//! junctions, up to [`MAX_EVALUATIONS`] structural analyses in all (each O(E log V)); past
//! that it adds, greedily, the junction that satisfies the most targets, and says the
//! answer may not be the smallest.

use std::collections::BTreeSet;

use super::component::{components, Component};
use super::isolability::{classes, fault_structure, Classes};
use super::structure::{Eq, Unknown};
use super::subsets::for_each_subset;
use crate::causality::equations::{self, Var};
use crate::causality::Mode;
use crate::graph::{BondGraph, JunctionKind, NodeId, NodeKind};

/// Structural analyses the exhaustive search may make before it turns greedy.
pub(crate) const MAX_EVALUATIONS: usize = 20_000;

/// Proposals listed at most, of the smallest size.
const MAX_PROPOSALS: usize = 10;

/// What the added detectors must achieve for the targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Goal {
    /// Each target shows in some residual.
    Detectable,
    /// Each target is told apart from every component that any placement could tell it from.
    Isolable,
}

/// A detector to add.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct NewDetector {
    /// `De` on a 0-junction, `Df` on a 1-junction.
    pub kind: &'static str,
    /// The junction, by its name in the model.
    pub junction: String,
}

/// Fault classes by component name.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NamedClasses {
    /// The classes of detectable components.
    pub classes: Vec<Vec<String>>,
    /// The undetectable ones.
    pub undetectable: Vec<String>,
}

/// One set of detectors that reaches the goal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Proposal {
    /// The detectors to add.
    pub detectors: Vec<NewDetector>,
    /// The classes of the model's components with them.
    pub classes: NamedClasses,
}

/// The answer of [`place`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Placement {
    /// The goal.
    pub goal: Goal,
    /// The components the goal is about.
    pub targets: Vec<String>,
    /// The classes with the model's detectors.
    pub now: NamedClasses,
    /// The classes with every unmeasured junction measured: the most detectors can give.
    pub most: NamedClasses,
    /// The smallest sets found that reach the goal (empty: the model already does, or no
    /// set of junctions can).
    pub proposals: Vec<Proposal>,
    /// Whether the model already reaches the goal.
    pub reached: bool,
    /// Whether every set of the proposals' size was tried (else they come from the greedy
    /// search and may not be the smallest).
    pub exhaustive: bool,
}

/// Why [`place`] cannot answer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlacementError {
    /// A target named no component: the name, and the component it is likely a slip for.
    UnknownComponent(String, Option<String>),
}

impl std::fmt::Display for PlacementError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlacementError::UnknownComponent(name, None) => {
                write!(f, "`{name}` is not a component of the model")
            }
            PlacementError::UnknownComponent(name, Some(near)) => {
                write!(
                    f,
                    "`{name}` is not a component of the model (did you mean `{near}`?)"
                )
            }
        }
    }
}

/// The analysis of one set of added detectors.
struct Trial {
    classes: Classes,
}

/// The model's structure, and how to add detectors to it.
struct Search<'m> {
    model: &'m BondGraph,
    components: Vec<Component>,
    system: equations::System,
    /// Unmeasured junctions, with the unknown a detector there would measure.
    junctions: Vec<(NodeId, Unknown)>,
}

impl Search<'_> {
    /// The classes with detectors added at `added` (positions in `junctions`).
    fn trial(&self, added: &[usize]) -> Trial {
        let (mut s, mut faults): (_, Vec<Eq>) = fault_structure(&self.system, &self.components);
        for &k in added {
            let (_, var) = self.junctions[k];
            let fault = s.add_var();
            s.push(vec![var, fault]);
            faults.push(s.push(vec![fault]));
        }
        Trial {
            classes: classes(&s, &faults),
        }
    }

    /// The components of the model (not the added detectors) in `c`'s class.
    fn group(&self, c: &Classes, target: usize) -> Option<BTreeSet<usize>> {
        let n = self.components.len();
        c.classes
            .iter()
            .find(|k| k.contains(&target))
            .map(|k| k.iter().copied().filter(|&i| i < n).collect())
    }

    fn named(&self, c: &Classes) -> NamedClasses {
        let n = self.components.len();
        let names = |k: &[usize]| -> Vec<String> {
            k.iter()
                .filter(|&&i| i < n)
                .map(|&i| self.components[i].name.clone())
                .collect()
        };
        NamedClasses {
            classes: c
                .classes
                .iter()
                .map(|k| names(k))
                .filter(|k| !k.is_empty())
                .collect(),
            undetectable: names(&c.undetectable),
        }
    }

    fn detector(&self, k: usize) -> NewDetector {
        let (j, _) = self.junctions[k];
        let node = self.model.node(j);
        NewDetector {
            kind: match node.junction_kind() {
                Some(JunctionKind::Zero) => "De",
                _ => "Df",
            },
            junction: node.name.clone(),
        }
    }
}

/// The smallest sets of detectors that make `targets` (component names; all when empty)
/// reach `goal`, in `model`.
pub(crate) fn place(
    model: &BondGraph,
    targets: &[String],
    goal: Goal,
) -> Result<Placement, PlacementError> {
    let components = components(model);
    let system = equations::build(model, Mode::Diagnosis);
    let measured: BTreeSet<NodeId> = model
        .nodes()
        .filter(|&d| matches!(model.node(d).kind, NodeKind::Detector(_)))
        .filter_map(|d| model.detector_junction(d))
        .collect();
    let junctions: Vec<(NodeId, Unknown)> = model
        .nodes()
        .filter(|&j| model.node(j).is_junction() && !measured.contains(&j))
        .filter_map(|j| system.var(Var::Common(j)).map(|v| (j, Unknown(v.0))))
        .collect();
    let wanted: Vec<usize> = if targets.is_empty() {
        (0..components.len()).collect()
    } else {
        targets
            .iter()
            .map(|t| {
                components.iter().position(|c| &c.name == t).ok_or_else(|| {
                    let names = components.iter().map(|c| c.name.as_str());
                    let near = crate::graph::closest(t, names.collect::<Vec<_>>().into_iter());
                    PlacementError::UnknownComponent(t.clone(), near.map(str::to_string))
                })
            })
            .collect::<Result<_, _>>()?
    };
    let search = Search {
        model,
        components,
        system,
        junctions,
    };
    let all: Vec<usize> = (0..search.junctions.len()).collect();
    let now = search.trial(&[]);
    let most = search.trial(&all);
    let satisfied = |t: &Trial, target: usize| match goal {
        Goal::Detectable => search.group(&t.classes, target).is_some(),
        Goal::Isolable => search.group(&t.classes, target) == search.group(&most.classes, target),
    };
    let done = |t: &Trial| wanted.iter().all(|&w| satisfied(t, w));
    let mut placement = Placement {
        goal,
        targets: wanted
            .iter()
            .map(|&w| search.components[w].name.clone())
            .collect(),
        now: search.named(&now.classes),
        most: search.named(&most.classes),
        proposals: Vec::new(),
        reached: done(&now),
        exhaustive: true,
    };
    if placement.reached || !done(&most) {
        return Ok(placement);
    }
    let mut budget = MAX_EVALUATIONS;
    for size in 1..=search.junctions.len() {
        let mut found = Vec::new();
        let complete = for_each_subset(search.junctions.len(), size, &mut budget, |set| {
            let t = search.trial(set);
            if done(&t) && found.len() < MAX_PROPOSALS {
                found.push(proposal(&search, set, &t));
            }
        });
        if !found.is_empty() && complete {
            placement.proposals = found;
            return Ok(placement);
        }
        if !complete {
            break;
        }
    }
    placement.exhaustive = false;
    placement.proposals = vec![greedy(&search, &wanted, &satisfied)];
    Ok(placement)
}

fn proposal(search: &Search, set: &[usize], t: &Trial) -> Proposal {
    Proposal {
        detectors: set.iter().map(|&k| search.detector(k)).collect(),
        classes: search.named(&t.classes),
    }
}

/// Adds, one at a time, the junction that satisfies the most targets (ties: the most
/// classes, then the first), until all are.
fn greedy(
    search: &Search,
    wanted: &[usize],
    satisfied: &dyn Fn(&Trial, usize) -> bool,
) -> Proposal {
    let mut set: Vec<usize> = Vec::new();
    loop {
        let t = search.trial(&set);
        let score = |t: &Trial| {
            (
                wanted.iter().filter(|&&w| satisfied(t, w)).count(),
                t.classes.classes.len(),
            )
        };
        if score(&t).0 == wanted.len() {
            return proposal(search, &set, &t);
        }
        let next = (0..search.junctions.len())
            .filter(|k| !set.contains(k))
            .map(|k| {
                let mut with = set.clone();
                with.push(k);
                (score(&search.trial(&with)), std::cmp::Reverse(k))
            })
            .max();
        let Some((_, std::cmp::Reverse(k))) = next else {
            return proposal(search, &set, &t);
        };
        set.push(k);
        set.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(file: &str) -> BondGraph {
        let path = format!("{}/../../models/{file}", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(path).expect("model");
        let (model, d) = crate::graph::load(&text);
        model.unwrap_or_else(|| panic!("{d:?}"))
    }

    fn detectors(p: &Proposal) -> Vec<String> {
        p.detectors
            .iter()
            .map(|d| format!("{} {}", d.kind, d.junction))
            .collect()
    }

    /// The DC motor measured by its current and speed already reaches the most any detector
    /// could give: nothing to add.
    #[test]
    fn the_dc_motor_needs_nothing() {
        let p = place(&load("dc_motor.bg"), &[], Goal::Isolable).expect("placement");
        assert!(p.reached);
        assert!(p.proposals.is_empty());
    }

    /// The four-mass chain measured at its ends: structurally, every mass is a class of its
    /// own already and each spring stays with its damper (one junction's balance holds
    /// both, whatever is measured): nothing to add for either goal.
    #[test]
    fn the_four_mass_chain_is_as_isolable_as_it_gets() {
        let model = load("four_mass_chain.bg");
        for goal in [Goal::Detectable, Goal::Isolable] {
            let p = place(&model, &[], goal).expect("placement");
            assert!(p.reached && p.proposals.is_empty(), "{goal:?}");
        }
    }

    /// The bench with its two encoders: the motor's resistor, inductor and source, its
    /// gyrator and its inertia and friction all share one residual, the electrical and
    /// mechanical balances of the motor merged through the unmeasured current. Measuring the
    /// current (`Df` on `elec`) splits that balance in two, as in the DC motor alone:
    /// `U Rm Lm` in the electrical one, `Jm fm Wm` in the mechanical one, the gyrator in
    /// both. No other single junction does it, and that one is enough, for the source `U`
    /// alone as for every component.
    #[test]
    fn the_bench_needs_the_motor_current() {
        let model = load("backlash_bench.bg");
        for targets in [vec![], vec!["U".to_string()]] {
            let p = place(&model, &targets, Goal::Isolable).expect("placement");
            assert!(!p.reached && p.exhaustive);
            assert_eq!(p.proposals.len(), 1, "{:?}", p.proposals);
            assert_eq!(detectors(&p.proposals[0]), ["Df elec"]);
        }
        let p = place(&model, &[], Goal::Isolable).expect("placement");
        let classes = &p.proposals[0].classes.classes;
        for group in [&["U", "Rm", "Lm"][..], &["motor"], &["Jm", "fm", "Wm"]] {
            assert!(classes.iter().any(|c| c == group), "{classes:?}");
        }
        // The gear is told apart by the encoders already.
        let gear = place(&model, &["gear".to_string()], Goal::Isolable).expect("placement");
        assert!(gear.reached);
    }

    /// The quarter-car with its two speed sensors: the wheel mass shares its class with the
    /// road input and the tyre, whose force is the wheel's only other load. Measuring that
    /// force (`De` on `tyre_f`) closes the wheel's balance on measured signals; nothing else
    /// does in one detector.
    #[test]
    fn the_quarter_car_needs_the_tyre_force() {
        let model = load("quarter_car.bg");
        let p = place(&model, &[], Goal::Isolable).expect("placement");
        assert!(!p.reached && p.exhaustive);
        assert_eq!(p.proposals.len(), 1, "{:?}", p.proposals);
        assert_eq!(detectors(&p.proposals[0]), ["De tyre_f"]);
        let classes = &p.proposals[0].classes.classes;
        assert!(classes.iter().any(|c| c == &["wheel"]), "{classes:?}");
        assert!(
            classes.iter().any(|c| c == &["road", "tyre"]),
            "{classes:?}"
        );
    }

    #[test]
    fn an_unknown_target_is_named() {
        let e = place(&load("dc_motor.bg"), &["nope".to_string()], Goal::Isolable);
        assert_eq!(
            e,
            Err(PlacementError::UnknownComponent("nope".into(), None))
        );
        // A slip gets the component it is likely for.
        let e = place(&load("dc_motor.bg"), &["Jn".to_string()], Goal::Isolable);
        let near = Some("Jm".to_string());
        assert_eq!(e, Err(PlacementError::UnknownComponent("Jn".into(), near)));
    }
}
