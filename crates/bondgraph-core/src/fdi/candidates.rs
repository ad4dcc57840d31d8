//! Residuals beyond one per detector, and the choice of a set of them.
//!
//! A residual that a fault of class `L` cannot reach is an ARR of the model with `L`'s
//! equations left out: the same derivation (causality, elimination), on fewer equations. One
//! derivation per fault class gives, for every pair of classes the structure can tell apart,
//! residuals that see one and not the other, where bgc can write them: a part of the model
//! whose only residual needs a law solved for an unknown it holds nonlinearly (the bench's
//! link torque `K z + w(z)` for the twist `z`) yields none, and the classes it would have
//! separated stay together (reported against the structural classes).
//!
//! Derivations cost a diagnosis each, so they are made for models of at most
//! [`MAX_DERIVATIONS`] classes; the choice among candidates is exhaustive within
//! [`MAX_SELECTIONS`] evaluations, then greedy.

use std::collections::{BTreeSet, HashMap};

use super::arr::{diagnose_freeing, Diagnosis};
use super::fsm::{arr_rows, Component};
use super::isolability::Classes;
use super::subsets::for_each_subset;
use crate::graph::BondGraph;
use crate::symbolic::Leaf;

/// Models with more fault classes keep one ARR per detector: each class costs a derivation
/// of the whole model (a 30-stage chain's 57 take over a minute).
pub const MAX_DERIVATIONS: usize = 32;

/// Candidates longer than this, written out, are not kept: a residual of a whole part of a
/// machine with every derivative its elimination needs is not one to evaluate on a bench.
/// The ARRs of the whole model are kept whatever their size.
pub const MAX_CANDIDATE_SIZE: u64 = 20_000;

/// The size of `root` written out as a tree.
fn written_size(pool: &crate::symbolic::Pool, root: crate::symbolic::ExprId) -> u64 {
    let mut size: HashMap<crate::symbolic::ExprId, u64> = HashMap::new();
    pool.visit_reachable(&[root], |id, node| {
        let s = crate::symbolic::children(node)
            .map(|c| size.get(&c).copied().unwrap_or(0))
            .fold(1u64, u64::saturating_add);
        size.insert(id, s);
    });
    size.get(&root).copied().unwrap_or(0)
}

/// Which residuals the product carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ResidualSet {
    /// One ARR per detector, as the reference paper does (the default).
    #[default]
    PerSensor,
    /// The smallest set that tells apart every class the candidates can, lowest total
    /// derivative order among those (exhaustive within a budget, then greedy).
    Best,
    /// Every candidate with a signature of its own.
    All,
}

/// A residual: an ARR of one of the derivations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Candidate {
    /// The derivation it comes from (0: the whole model).
    pub source: usize,
    /// Its position among that derivation's ARRs.
    pub arr: usize,
    /// The components (rows) whose fault it shows, increasing.
    pub rows: Vec<usize>,
    /// The components whose equations were left out to derive it.
    pub without: Vec<usize>,
    /// The highest derivative it reads of any signal.
    pub order: u32,
}

/// A derivation without a class that should have given residuals seeing some components,
/// and gave none that bgc can write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unrealised {
    /// The components left out.
    pub without: Vec<usize>,
    /// The components a residual without them could show and no written one does.
    pub unseen: Vec<usize>,
    /// Those of `unseen` whose equations a written residual of the derivation does use, and
    /// whose terms cancel in it: a dependence the structure counts is not there (the bench's
    /// backlash torque, taken from one shaft and given to the other; a bridge's branch
    /// currents in the sum of its nodes' balances).
    pub cancelled: Vec<usize>,
    /// Whether the derivation wrote as many residuals as the structure without these
    /// components has redundancy: then no residual without them shows any of `unseen`, and
    /// `cancelled` is all of it.
    pub complete: bool,
    /// What the derivation met, in the model's names.
    pub reasons: Vec<String>,
}

/// The derivations and the residuals found in them, one per signature.
pub struct Candidates {
    /// The derivations that fell short of the structure, and why.
    pub unrealised: Vec<Unrealised>,
    /// The derivations: the whole model first, then one per class left out.
    pub sources: Vec<Diagnosis>,
    /// The residuals: every ARR of the whole model first, then each candidate with a
    /// signature none before it has.
    pub list: Vec<Candidate>,
    /// Whether the model had too many classes for derivations beyond the whole model.
    pub capped: bool,
}

/// The highest derivative a residual reads.
fn order(d: &Diagnosis, k: usize) -> u32 {
    d.causal
        .system
        .pool
        .leaves(d.arrs[k].expanded)
        .into_iter()
        .filter_map(|l| match l {
            Leaf::Sensor(_, n) | Leaf::Input(_, n) => Some(n),
            _ => None,
        })
        .max()
        .unwrap_or(0)
}

/// The candidates of `model`: its own ARRs (`base`, showing `base_rows` each, as its FSM
/// found), then those of the model without each class of `possible` in turn.
pub fn candidates(
    model: &BondGraph,
    base: Diagnosis,
    base_rows: Vec<Vec<usize>>,
    components: &[Component],
    possible: &Classes,
) -> Candidates {
    let capped = possible.classes.len() > MAX_DERIVATIONS;
    let mut sources = vec![base];
    let mut without: Vec<Vec<usize>> = vec![Vec::new()];
    if !capped {
        for class in &possible.classes {
            let nodes: BTreeSet<_> = class.iter().filter_map(|&i| components[i].node).collect();
            let lets: BTreeSet<_> = class
                .iter()
                .filter_map(|&i| components[i].modulation)
                .collect();
            let drop = |eq: &crate::causality::equations::Equation| {
                nodes.contains(&eq.owner) || eq.lets.iter().any(|l| lets.contains(l))
            };
            let free: Vec<_> = lets.iter().copied().collect();
            sources.push(diagnose_freeing(model, &free, &drop));
            without.push(class.clone());
        }
    }
    // The whole model's ARRs are all kept, whatever their signatures and sizes.
    let mut list: Vec<Candidate> = base_rows
        .into_iter()
        .enumerate()
        .map(|(arr, rows)| Candidate {
            source: 0,
            arr,
            order: order(&sources[0], arr),
            without: Vec::new(),
            rows,
        })
        .collect();
    if sources.len() == 1 {
        return Candidates {
            sources,
            list,
            capped,
            unrealised: Vec::new(),
        };
    }
    let mut seen: HashMap<Vec<usize>, usize> = list
        .iter()
        .enumerate()
        .map(|(k, c)| (c.rows.clone(), k))
        .collect();
    let (structure, faults) =
        super::isolability::fault_structure(&sources[0].causal.system, components);
    let mut unrealised = Vec::new();
    for (source, d) in sources.iter().enumerate().skip(1) {
        let mut shown: BTreeSet<usize> = BTreeSet::new();
        let mut written: Vec<&super::arr::Arr> = Vec::new();
        let used = |written: &[&super::arr::Arr], i: usize| {
            let c = &components[i];
            written.iter().any(|a| {
                c.node.is_some_and(|n| a.nodes.contains(&n))
                    || c.modulation.is_some_and(|l| a.lets.contains(&l))
            })
        };
        for (arr, rows) in arr_rows(model, d, components).into_iter().enumerate() {
            if written_size(&d.causal.system.pool, d.arrs[arr].residual) > MAX_CANDIDATE_SIZE {
                continue;
            }
            written.push(&d.arrs[arr]);
            shown.extend(rows.iter().copied());
            if rows.is_empty() {
                continue;
            }
            // A component left out that the residual still shows (a law reading a sensor
            // left out) is not one it is without.
            let c = Candidate {
                source,
                arr,
                order: order(d, arr),
                without: without[source]
                    .iter()
                    .copied()
                    .filter(|i| rows.binary_search(i).is_err())
                    .collect(),
                rows,
            };
            match seen.get(&c.rows) {
                // One per signature: the per-detector one, else the lowest order.
                Some(&k) if c.order < list[k].order && list[k].source > 0 => list[k] = c,
                Some(_) => {}
                None => {
                    seen.insert(c.rows.clone(), list.len());
                    list.push(c);
                }
            }
        }
        let left_out = &without[source];
        let Some(&first) = left_out.first() else {
            continue;
        };
        let could = super::isolability::seen_without(&structure, &faults, faults[first]);
        let unseen: Vec<usize> = (0..components.len())
            .filter(|&i| could[i] && !shown.contains(&i) && !left_out.contains(&i))
            .collect();
        if !unseen.is_empty() {
            let mut active = vec![true; structure.len()];
            active[faults[first].0 as usize] = false;
            let redundancy =
                active.iter().filter(|&&a| a).count() - structure.matching(&active).size();
            let complete = written.len() >= redundancy;
            unrealised.push(Unrealised {
                without: left_out.clone(),
                cancelled: unseen
                    .iter()
                    .copied()
                    .filter(|&i| complete || used(&written, i))
                    .collect(),
                complete,
                unseen,
                // A detector left without an ARR is what is being reported, not why.
                reasons: d
                    .problems
                    .iter()
                    .map(|p| p.message.clone())
                    .filter(|m| !m.starts_with("the detector `"))
                    .collect(),
            });
        }
    }
    Candidates {
        sources,
        list,
        capped,
        unrealised,
    }
}

/// The structural classes `possible`, merged where derivations prove the structure counts
/// too much: when bgc wrote every residual the equations allow without class `C` and the
/// terms of a component of class `X` cancel in each, every residual that shows `X` shows
/// `C` too. That containment is transitive, so classes that contain each other in a cycle
/// show in the same residuals: one class. O(classes²) on at most [`MAX_DERIVATIONS`].
pub fn bound(possible: &Classes, unrealised: &[Unrealised]) -> Classes {
    let n = possible.classes.len();
    let mut class_of: HashMap<usize, usize> = HashMap::new();
    for (k, class) in possible.classes.iter().enumerate() {
        for &i in class {
            class_of.insert(i, k);
        }
    }
    // within[x][c]: every residual showing class x shows class c.
    let mut within = vec![vec![false; n]; n];
    for (k, row) in within.iter_mut().enumerate() {
        row[k] = true;
    }
    for u in unrealised.iter().filter(|u| u.complete) {
        let Some(&c) = u.without.first().and_then(|i| class_of.get(i)) else {
            continue;
        };
        for x in u.cancelled.iter().filter_map(|i| class_of.get(i)) {
            within[*x][c] = true;
        }
    }
    for m in 0..n {
        let through = within[m].clone();
        for row in within.iter_mut().filter(|row| row[m]) {
            for (x, &y) in row.iter_mut().zip(&through) {
                *x |= y;
            }
        }
    }
    let mut labels: Vec<Option<usize>> = vec![None; class_of.len() + possible.undetectable.len()];
    for (k, class) in possible.classes.iter().enumerate() {
        let first = (0..=k).find(|&j| within[k][j] && within[j][k]).unwrap_or(k);
        for &i in class {
            if let Some(l) = labels.get_mut(i) {
                *l = Some(first);
            }
        }
    }
    Classes::from_labels(&labels)
}

/// The classes a set of residuals tells apart, over `n` components.
pub fn classes_of(list: &[&Candidate], n: usize) -> Classes {
    let mut marks: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, c) in list.iter().enumerate() {
        for &r in &c.rows {
            marks[r].push(k);
        }
    }
    super::isolability::of_signatures(&marks)
}

/// The candidates (by position in `list`) that `set` keeps, over `n` components.
pub fn select(list: &[Candidate], n: usize, set: ResidualSet) -> Vec<usize> {
    match set {
        ResidualSet::PerSensor => (0..list.len()).filter(|&k| list[k].source == 0).collect(),
        ResidualSet::All => (0..list.len()).collect(),
        ResidualSet::Best => best(list, n),
    }
}

/// Set evaluations the exact search of [`best`] may make before it turns greedy.
pub const MAX_SELECTIONS: usize = 100_000;

/// The smallest set of candidates whose classes are those of every candidate together: every
/// set of one, then two… candidates while [`MAX_SELECTIONS`] lasts, the lowest total
/// derivative order among the smallest that do; past the budget, [`greedy`].
fn best(list: &[Candidate], n: usize) -> Vec<usize> {
    let all: Vec<&Candidate> = list.iter().collect();
    let target = classes_of(&all, n);
    let mut budget = MAX_SELECTIONS;
    for size in 1..=list.len() {
        let mut found: Option<(u32, Vec<usize>)> = None;
        let complete = for_each_subset(list.len(), size, &mut budget, |set| {
            let picked: Vec<&Candidate> = set.iter().map(|&k| &list[k]).collect();
            if classes_of(&picked, n) != target {
                return;
            }
            let order = picked.iter().map(|c| c.order).sum();
            if found.as_ref().is_none_or(|(o, _)| order < *o) {
                found = Some((order, set.to_vec()));
            }
        });
        if !complete {
            break;
        }
        if let Some((_, set)) = found {
            return set;
        }
    }
    greedy(list, n, &target)
}

/// Greedy: the residual that splits the most pairs of components still together (detection
/// counted as splitting from the undetectable), lowest order then fewest components on ties,
/// until the classes are `target`.
fn greedy(list: &[Candidate], n: usize, target: &Classes) -> Vec<usize> {
    // The group of each component: residuals chosen so far it shows in.
    let mut group: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut chosen: Vec<usize> = Vec::new();
    loop {
        let picked: Vec<&Candidate> = chosen.iter().map(|&k| &list[k]).collect();
        if classes_of(&picked, n) == *target || chosen.len() == list.len() {
            break;
        }
        let mut sizes: HashMap<&[usize], usize> = HashMap::new();
        for g in &group {
            *sizes.entry(g.as_slice()).or_default() += 1;
        }
        let score = |c: &Candidate| {
            let mut inside: HashMap<&[usize], usize> = HashMap::new();
            for &r in &c.rows {
                *inside.entry(group[r].as_slice()).or_default() += 1;
            }
            inside
                .iter()
                .map(|(g, &k)| k * (sizes[g] - k))
                .sum::<usize>()
        };
        let next = (0..list.len())
            .filter(|k| !chosen.contains(k))
            .map(|k| (score(&list[k]), k))
            .filter(|&(s, _)| s > 0)
            .max_by(|a, b| {
                a.0.cmp(&b.0)
                    .then(list[b.1].order.cmp(&list[a.1].order))
                    .then(list[b.1].rows.len().cmp(&list[a.1].rows.len()))
                    .then(b.1.cmp(&a.1))
            });
        let Some((_, k)) = next else { break };
        for &r in &list[k].rows {
            group[r].push(chosen.len());
        }
        chosen.push(k);
    }
    chosen.sort_unstable();
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    fn proof(without: usize, cancelled: &[usize], complete: bool) -> Unrealised {
        Unrealised {
            without: vec![without],
            unseen: cancelled.to_vec(),
            cancelled: cancelled.to_vec(),
            complete,
            reasons: Vec::new(),
        }
    }

    /// Classes merge where complete derivations prove containment both ways, through a
    /// cycle too; one way, or from an incomplete derivation, they stay apart.
    #[test]
    fn bound_merges_the_classes_that_contain_each_other() {
        let possible = Classes {
            classes: vec![vec![0], vec![1, 2], vec![3], vec![4], vec![5]],
            undetectable: vec![6],
        };
        let proofs = [
            // 0 ⊆ {1,2} ⊆ 3 ⊆ 0: one class.
            proof(1, &[0], true),
            proof(3, &[2], true),
            proof(0, &[3], true),
            // 5 ⊆ 4 only: apart.
            proof(4, &[5], true),
            // 4 ⊆ 5 from an incomplete derivation: no proof.
            proof(5, &[4], false),
        ];
        let b = bound(&possible, &proofs);
        assert_eq!(b.classes, vec![vec![0, 1, 2, 3], vec![4], vec![5]]);
        assert_eq!(b.undetectable, vec![6]);
        assert_eq!(bound(&possible, &[]), possible);
    }
}
