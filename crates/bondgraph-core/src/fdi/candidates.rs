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
//! A derivation of the whole model costs a diagnosis, so above [`MAX_DERIVATIONS`] classes
//! each class is left out of the part of the model around it instead (linear in the
//! classes). The choice among candidates is exhaustive within a budget, then a lazy greedy
//! (near-linear). Where the derivations fall short of the structure, [`Unrealised`] says what
//! is missing and, where bgc can prove it, that the structure counts a dependence that cancels
//! ([`bound`]).

use std::collections::{BTreeSet, HashMap};

use petgraph::Direction;

use super::arr::{diagnose_freeing, diagnose_in, Diagnosis};
use super::component::{Component, ComponentKind};
use super::fsm::{arr_rows_indexed, RowIndex};
use super::isolability::Classes;
use super::subsets::for_each_subset;
use crate::causality::equations::Equation;
use crate::graph::{BondGraph, ElementKind, LetId, NodeId, NodeKind, ParamId};
use crate::symbolic::Leaf;

/// Models with more fault classes derive each class's residuals on the part of the model
/// around it: a derivation of the whole model per class costs too much (a 30-stage chain's
/// 57 take over a minute).
pub const MAX_DERIVATIONS: usize = 32;

/// Candidates longer than this, written out, are not kept: a residual of a whole part of a
/// machine with every derivative its elimination needs is not one to evaluate on a bench.
/// The ARRs of the whole model are kept whatever their size.
pub const MAX_CANDIDATE_SIZE: u64 = 20_000;

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
    /// Each detector's simulated residual only: its reading against a copy of the model
    /// that the inputs drive from rest (the output error), one per detector.
    Simulated,
    /// Each detector's reading against a copy of the part of the model that the inputs and
    /// the other detectors' measurements drive from rest, one per detector where another
    /// detector measures a state (see `fdi::partial`).
    Partial,
    /// One ARR per detector and, beside them, each detector's partial copy where the model
    /// has one (see [`ResidualSet::Partial`]): a bank whose residuals each have a test, the
    /// ARRs needing no initial state, the copies filtering the noise through the model.
    Bank,
}

impl ResidualSet {
    /// Whether it is one residual per detector, with no candidates derived beyond the whole
    /// model's.
    pub(crate) fn per_detector(self) -> bool {
        matches!(
            self,
            ResidualSet::PerSensor
                | ResidualSet::Simulated
                | ResidualSet::Partial
                | ResidualSet::Bank
        )
    }
}

/// The cost of a simulated residual in the choice of a set: above any derivative order an ARR
/// reads, because it holds only from a known initial state and drifts with the model's errors.
pub(crate) const SIMULATED_COST: u32 = 1_000;

/// Where a candidate residual comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Origin {
    /// An ARR of one of the derivations.
    Derived {
        /// The derivation (0: the whole model).
        source: usize,
        /// Its position among that derivation's ARRs.
        arr: usize,
    },
    /// A detector's simulated residual, by position in the list of them (see
    /// [`super::simulated`]).
    Simulated(usize),
}

/// A residual: an ARR of one of the derivations, or a detector's simulated residual.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Candidate {
    /// Where it comes from.
    pub origin: Origin,
    /// The components (rows) whose fault it shows, increasing.
    pub rows: Vec<usize>,
    /// The components whose equations were left out to derive it.
    pub without: Vec<usize>,
    /// The highest derivative it reads of any signal.
    pub order: u32,
}

impl Candidate {
    /// Whether it is one of the whole model's ARRs, one per detector.
    pub(crate) fn is_per_sensor(&self) -> bool {
        matches!(self.origin, Origin::Derived { source: 0, .. })
    }

    /// What choosing it costs: its derivative order, and [`SIMULATED_COST`] for a simulated
    /// residual, so that one is chosen only for what no relation shows.
    pub(crate) fn cost(&self) -> u32 {
        match self.origin {
            Origin::Derived { .. } => self.order,
            Origin::Simulated(_) => SIMULATED_COST,
        }
    }

    /// The derivation and ARR it is, unless it is simulated.
    pub(crate) fn derived(&self) -> Option<(usize, usize)> {
        match self.origin {
            Origin::Derived { source, arr } => Some((source, arr)),
            Origin::Simulated(_) => None,
        }
    }
}

/// A derivation without a class that should have given residuals seeing some components,
/// and gave none that bgc can write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Unrealised {
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
pub(crate) struct Candidates {
    /// The derivations that fell short of the structure, and why.
    pub unrealised: Vec<Unrealised>,
    /// The derivations: the whole model first, then one per class left out.
    pub sources: Vec<Diagnosis>,
    /// The residuals: every ARR of the whole model first, then each candidate with a
    /// signature none before it has.
    pub list: Vec<Candidate>,
    /// Whether the model had too many classes for whole-model derivations: each class was left
    /// out of the part of the model around it, and no shortfall was analysed.
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
/// found), then those of the model without each class of `possible` in turn: derived on the
/// whole model up to [`MAX_DERIVATIONS`] classes, on a part around each class above.
pub(crate) fn candidates(
    model: &BondGraph,
    base: Diagnosis,
    base_rows: Vec<Vec<usize>>,
    components: &[Component],
    possible: &Classes,
) -> Candidates {
    // The whole model's ARRs are all kept, whatever their signatures and sizes.
    let list: Vec<Candidate> = base_rows
        .into_iter()
        .enumerate()
        .map(|(arr, rows)| Candidate {
            origin: Origin::Derived { source: 0, arr },
            order: order(&base, arr),
            without: Vec::new(),
            rows,
        })
        .collect();
    let mut found = Found {
        seen: list
            .iter()
            .enumerate()
            .map(|(k, c)| (c.rows.clone(), k))
            .collect(),
        list,
        index: RowIndex::new(components),
    };
    if possible.classes.is_empty() {
        return Candidates {
            sources: vec![base],
            list: found.list,
            capped: false,
            unrealised: Vec::new(),
        };
    }
    if possible.classes.len() > MAX_DERIVATIONS {
        let sources = local(model, base, components, possible, &mut found);
        return Candidates {
            sources,
            list: found.list,
            capped: true,
            unrealised: Vec::new(),
        };
    }
    let (structure, faults) = super::isolability::fault_structure(&base.causal.system, components);
    let mut sources = vec![base];
    let mut unrealised = Vec::new();
    for class in &possible.classes {
        let (free, drop) = leaving_out(components, class);
        let d = diagnose_freeing(model, &free, &drop);
        let offered = found.offer(model, components, sources.len(), &d, class);
        if let Some(u) = shortfall(components, &structure, &faults, &d, class, &offered) {
            unrealised.push(u);
        }
        sources.push(d);
    }
    Candidates {
        sources,
        list: found.list,
        capped: false,
        unrealised,
    }
}

/// The `let`s of `class` to hold as unknowns, and which equations to leave out: those its
/// elements and detectors own, and those using its `let`s that no source scales.
fn leaving_out(
    components: &[Component],
    class: &[usize],
) -> (Vec<LetId>, impl Fn(&Equation) -> bool) {
    let nodes: BTreeSet<NodeId> = class.iter().filter_map(|&i| components[i].node).collect();
    let lets: BTreeSet<LetId> = class
        .iter()
        .filter_map(|&i| components[i].modulation)
        .collect();
    let free = lets.iter().copied().collect();
    let drop =
        move |eq: &Equation| nodes.contains(&eq.owner) || eq.lets.iter().any(|l| lets.contains(l));
    (free, drop)
}

/// The candidates so far, one per signature.
struct Found {
    list: Vec<Candidate>,
    seen: HashMap<Vec<usize>, usize>,
    index: RowIndex,
}

/// What one derivation gave: the components its written residuals show, and those
/// residuals.
struct Offered {
    shown: BTreeSet<usize>,
    written: Vec<usize>,
    /// Whether one of its residuals became a candidate.
    kept: bool,
}

impl Found {
    /// Offers the residuals of `d`, derived without `left_out`, as candidates from `source`.
    fn offer(
        &mut self,
        model: &BondGraph,
        components: &[Component],
        source: usize,
        d: &Diagnosis,
        left_out: &[usize],
    ) -> Offered {
        let mut out = Offered {
            shown: BTreeSet::new(),
            written: Vec::new(),
            kept: false,
        };
        let rows = arr_rows_indexed(model, d, components, &self.index);
        for (arr, rows) in rows.into_iter().enumerate() {
            if d.causal.system.pool.written_size(d.arrs[arr].residual) > MAX_CANDIDATE_SIZE {
                continue;
            }
            out.written.push(arr);
            out.shown.extend(rows.iter().copied());
            if rows.is_empty() {
                continue;
            }
            // A component left out that the residual still shows (a law reading a sensor
            // left out) is not one it is without.
            let c = Candidate {
                origin: Origin::Derived { source, arr },
                order: order(d, arr),
                without: left_out
                    .iter()
                    .copied()
                    .filter(|i| rows.binary_search(i).is_err())
                    .collect(),
                rows,
            };
            match self.seen.get(&c.rows) {
                // One per signature: the per-detector one, else the lowest order.
                Some(&k) if c.order < self.list[k].order && !self.list[k].is_per_sensor() => {
                    self.list[k] = c;
                    out.kept = true;
                }
                Some(_) => {}
                None => {
                    self.seen.insert(c.rows.clone(), self.list.len());
                    self.list.push(c);
                    out.kept = true;
                }
            }
        }
        out
    }
}

/// What the structure says a residual without `left_out` could show and the derivation's
/// residuals do not, with why; `None` when nothing is missing.
fn shortfall(
    components: &[Component],
    structure: &super::structure::Structure,
    faults: &[super::structure::Eq],
    d: &Diagnosis,
    left_out: &[usize],
    offered: &Offered,
) -> Option<Unrealised> {
    let &first = left_out.first()?;
    let could = super::isolability::seen_without(structure, faults, faults[first]);
    let unseen: Vec<usize> = (0..components.len())
        .filter(|&i| could[i] && !offered.shown.contains(&i) && !left_out.contains(&i))
        .collect();
    if unseen.is_empty() {
        return None;
    }
    let mut active = vec![true; structure.len()];
    active[faults[first].index()] = false;
    let redundancy = active.iter().filter(|&&a| a).count() - structure.matching(&active).size();
    let complete = offered.written.len() >= redundancy;
    let used = |i: usize| {
        let c = &components[i];
        offered.written.iter().any(|&k| {
            let a = &d.arrs[k];
            c.node.is_some_and(|n| a.nodes.contains(&n))
                || c.modulation.is_some_and(|l| a.lets.contains(&l))
        })
    };
    Some(Unrealised {
        without: left_out.to_vec(),
        cancelled: unseen
            .iter()
            .copied()
            .filter(|&i| complete || used(i))
            .collect(),
        complete,
        unseen,
        // A detector left without an ARR is what is being reported, not why.
        reasons: d
            .problems
            .iter()
            .map(|p| p.message.clone())
            .filter(|m| !m.starts_with("the detector `"))
            .chain(two_ports(components, left_out))
            .collect(),
    })
}

/// Why a residual without a TF or GY is missing when it is: its fault is in both of its
/// laws, and the structure eliminates it between them, which bgc's derivation does not.
fn two_ports<'c>(
    components: &'c [Component],
    left_out: &'c [usize],
) -> impl Iterator<Item = String> + 'c {
    left_out.iter().filter_map(|&i| {
        let c = &components[i];
        matches!(
            c.kind,
            ComponentKind::Element(ElementKind::TF | ElementKind::MTF | ElementKind::GY | ElementKind::MGY)
        )
        .then(|| {
            format!(
                "a residual without `{}` uses its two laws with its modulus eliminated between them (the power it passes, e1·f1 = e2·f2), which bgc does not derive",
                c.name
            )
        })
    })
}

/// Detectors of other classes a part grows to hold: two on each side of a class on a line.
pub const WINDOW_DETECTORS: usize = 4;

/// The most nodes a part may hold (then it stops at the end of a layer): twenty stages of a
/// mass–spring chain, enough for the residuals that span three stretches between detectors
/// five masses apart (on such a chain they tell every stage apart).
pub(crate) const MAX_WINDOW: usize = 100;

/// A part that holds this many nodes stops growing (at the end of a layer) once its laws hold
/// more than [`MAX_WINDOW_PARAMETERS`] parameters: about eight stages of a chain.
pub(crate) const SMALL_WINDOW: usize = 40;

/// The parameters a part may hold past [`SMALL_WINDOW`] nodes. The residuals of a part grow
/// with the product of its stretches' operators, whose coefficients are polynomials in the
/// parameters: with a parameter per element, a part of 100 nodes takes minutes and gigabytes
/// where one of 40 takes milliseconds; with parameters shared along the chain, 100 nodes
/// take milliseconds.
pub(crate) const MAX_WINDOW_PARAMETERS: usize = 16;

/// Candidates of a model with more than [`MAX_DERIVATIONS`] classes: each class left out of
/// the part of the model around it, grown layer by layer from its nodes until it holds
/// [`WINDOW_DETECTORS`] detectors of other classes (at most [`MAX_WINDOW`] nodes, and
/// [`SMALL_WINDOW`] when its laws hold many parameters). On a
/// model whose detectors are spread, each part is bounded, so the whole is linear in the
/// classes. Only the derivations that gave a candidate are kept.
fn local(
    model: &BondGraph,
    base: Diagnosis,
    components: &[Component],
    possible: &Classes,
    found: &mut Found,
) -> Vec<Diagnosis> {
    let mut owners: HashMap<LetId, Vec<NodeId>> = HashMap::new();
    for eq in &base.causal.system.equations {
        for &l in &eq.lets {
            owners.entry(l).or_default().push(eq.owner);
        }
    }
    let mut sources = vec![base];
    for class in &possible.classes {
        let mut seeds: Vec<NodeId> = Vec::new();
        for &i in class {
            seeds.extend(components[i].node);
            if let Some(l) = components[i].modulation {
                seeds.extend(owners.get(&l).into_iter().flatten().copied());
            }
        }
        let scope = window(model, &seeds);
        let (free, drop) = leaving_out(components, class);
        let d = diagnose_in(model, &free, &scope, &drop);
        if found
            .offer(model, components, sources.len(), &d, class)
            .kept
        {
            sources.push(d);
        }
    }
    sources
}

/// The parameters an element's law names directly.
fn parameters_of(model: &BondGraph, n: NodeId) -> Vec<ParamId> {
    let mut out = Vec::new();
    if let NodeKind::Element(_, law) = &model.node(n).kind {
        law.expr().for_each_leaf(&mut |s| {
            if let crate::graph::Signal::Param(p) = s {
                out.push(*p);
            }
        });
    }
    out
}

/// The nodes around `seeds`, in increasing order (see [`local`]).
fn window(model: &BondGraph, seeds: &[NodeId]) -> Vec<NodeId> {
    let is_detector = |n: NodeId| matches!(model.node(n).kind, NodeKind::Detector(_));
    let mut inside: BTreeSet<NodeId> = seeds.iter().copied().collect();
    let mut layer: Vec<NodeId> = inside.iter().copied().collect();
    let mut detectors = 0;
    let mut parameters: BTreeSet<ParamId> = BTreeSet::new();
    for &n in &inside {
        parameters.extend(parameters_of(model, n));
    }
    let large = |inside: &BTreeSet<NodeId>, parameters: &BTreeSet<ParamId>| {
        inside.len() >= MAX_WINDOW
            || (inside.len() >= SMALL_WINDOW && parameters.len() > MAX_WINDOW_PARAMETERS)
    };
    while !layer.is_empty() && detectors < WINDOW_DETECTORS && !large(&inside, &parameters) {
        let mut next = Vec::new();
        for &n in &layer {
            let mut bonds = model.bonds_at(n, Direction::Incoming);
            bonds.extend(model.bonds_at(n, Direction::Outgoing));
            for b in bonds {
                let (tail, head) = model.ends(b);
                let other = if tail == n { head } else { tail };
                if inside.insert(other) {
                    detectors += usize::from(is_detector(other));
                    parameters.extend(parameters_of(model, other));
                    next.push(other);
                }
            }
        }
        layer = next;
    }
    inside.into_iter().collect()
}

/// The structural classes `possible`, merged where derivations prove the structure counts
/// too much: when bgc wrote every residual the equations allow without class `C` and the
/// terms of a component of class `X` cancel in each, every residual that shows `X` shows
/// `C` too. That containment is transitive, so classes that contain each other in a cycle
/// show in the same residuals: one class. O(classes²) on at most [`MAX_DERIVATIONS`].
pub(crate) fn bound(possible: &Classes, unrealised: &[Unrealised]) -> Classes {
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
pub(crate) fn classes_of(list: &[&Candidate], n: usize) -> Classes {
    let mut marks: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, c) in list.iter().enumerate() {
        for &r in &c.rows {
            marks[r].push(k);
        }
    }
    super::isolability::of_signatures(&marks)
}

/// The candidates (by position in `list`) that `set` keeps, over `n` components.
pub(crate) fn select(list: &[Candidate], n: usize, set: ResidualSet) -> Vec<usize> {
    match set {
        ResidualSet::PerSensor => (0..list.len())
            .filter(|&k| list[k].is_per_sensor())
            .collect(),
        ResidualSet::All => (0..list.len()).collect(),
        ResidualSet::Best => best(list, n),
        ResidualSet::Simulated | ResidualSet::Partial => (0..list.len())
            .filter(|&k| matches!(list[k].origin, Origin::Simulated(_)))
            .collect(),
        ResidualSet::Bank => (0..list.len())
            .filter(|&k| list[k].is_per_sensor() || matches!(list[k].origin, Origin::Simulated(_)))
            .collect(),
    }
}

/// Set evaluations the exact search of [`best`] may make before it turns greedy.
pub(crate) const MAX_SELECTIONS: usize = 100_000;

/// Work (set evaluations times components) the exact search may do: on a large model fewer
/// sets are tried, so that the search stays within about a second whatever the size.
pub(crate) const MAX_SELECTION_WORK: usize = 20_000_000;

/// The smallest set of candidates whose classes are those of every candidate together: every
/// set of one, then two… candidates while the budget lasts ([`MAX_SELECTIONS`] sets, at most
/// [`MAX_SELECTION_WORK`] set-components), the lowest total [`Candidate::cost`] among the
/// smallest that do; past the budget, [`greedy`].
fn best(list: &[Candidate], n: usize) -> Vec<usize> {
    let all: Vec<&Candidate> = list.iter().collect();
    let target = classes_of(&all, n);
    let mut budget = MAX_SELECTIONS.min(MAX_SELECTION_WORK / n.max(1));
    for size in 1..=list.len() {
        let mut found: Option<(u32, Vec<usize>)> = None;
        let complete = for_each_subset(list.len(), size, &mut budget, |set| {
            let picked: Vec<&Candidate> = set.iter().map(|&k| &list[k]).collect();
            if classes_of(&picked, n) != target {
                return;
            }
            let order = picked.iter().map(|c| c.cost()).sum();
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
    greedy(list, n)
}

/// Greedy: the residual that splits the most pairs of components still together (detection
/// counted as splitting from the undetectable), lowest cost then fewest components then
/// first on ties, until no residual splits a pair: then the classes are those of every
/// candidate. The pairs a residual splits only fall as the groups refine, so a score
/// computed earlier bounds the current one: each round takes the best stale score, scores
/// it again, and keeps it if it still leads (lazy greedy, the same choices as scoring every
/// candidate each round). Groups are refined in place: O(Σ rows · log candidates).
fn greedy(list: &[Candidate], n: usize) -> Vec<usize> {
    use std::collections::BinaryHeap;
    // The group of each component, and each group's size. Group 0 starts with one member
    // more, shown by no residual: the undetectable, which detection tells a component from.
    let mut group: Vec<usize> = vec![0; n];
    let mut sizes: Vec<usize> = vec![n + 1];
    let score = |group: &[usize], sizes: &[usize], c: &Candidate| -> usize {
        let mut inside: HashMap<usize, usize> = HashMap::new();
        for &r in &c.rows {
            *inside.entry(group[r]).or_default() += 1;
        }
        inside.iter().map(|(g, &k)| k * (sizes[*g] - k)).sum()
    };
    // Larger is better: score, then lower order, fewer rows, earlier.
    let key = |s: usize, k: usize| {
        (
            s,
            std::cmp::Reverse(list[k].cost()),
            std::cmp::Reverse(list[k].rows.len()),
            std::cmp::Reverse(k),
        )
    };
    let mut heap: BinaryHeap<_> = (0..list.len())
        .map(|k| key(score(&group, &sizes, &list[k]), k))
        .filter(|t| t.0 > 0)
        .collect();
    let mut chosen: Vec<usize> = Vec::new();
    while let Some(top) = heap.pop() {
        let k = top.3 .0;
        let now = key(score(&group, &sizes, &list[k]), k);
        if now.0 == 0 {
            continue;
        }
        if heap.peek().is_some_and(|next| *next > now) {
            heap.push(now);
            continue;
        }
        // Split each group the residual cuts: its members in it move to a new group.
        let mut moved: HashMap<usize, usize> = HashMap::new();
        for &r in &list[k].rows {
            let g = group[r];
            let new = *moved.entry(g).or_insert_with(|| {
                sizes.push(0);
                sizes.len() - 1
            });
            sizes[g] -= 1;
            sizes[new] += 1;
            group[r] = new;
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

    /// On many pseudo-random candidate lists, the greedy choice tells apart every class the
    /// whole list does, with no more residuals than classes.
    #[test]
    fn greedy_reaches_the_classes_of_every_candidate() {
        let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move |m: u64| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 33) % m
        };
        for _ in 0..200 {
            let n = 1 + next(40) as usize;
            let list: Vec<Candidate> = (0..next(30))
                .map(|arr| {
                    let mut rows: Vec<usize> =
                        (0..1 + next(6)).map(|_| next(n as u64) as usize).collect();
                    rows.sort_unstable();
                    rows.dedup();
                    Candidate {
                        origin: Origin::Derived {
                            source: 1,
                            arr: arr as usize,
                        },
                        rows,
                        without: Vec::new(),
                        order: next(5) as u32,
                    }
                })
                .collect();
            let all: Vec<&Candidate> = list.iter().collect();
            let picked = greedy(&list, n);
            let chosen: Vec<&Candidate> = picked.iter().map(|&k| &list[k]).collect();
            assert_eq!(classes_of(&chosen, n), classes_of(&all, n));
            // Each pick split something when it was taken: no more picks than classes.
            let whole = classes_of(&chosen, n);
            assert!(chosen.len() <= whole.classes.len());
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
