//! Which faults can be told apart: by any residual the model's equations allow (structural
//! isolability), and by a given set of residuals (their signatures).
//!
//! Structurally, a fault of component `c` is an unknown `f_c` added to each equation the
//! component owns, with one more equation `f_c = 0`: the component's fault is then that one
//! equation. A fault is detectable when its equation is in the over-determined part `M⁺` of
//! the model; `f_i` is isolable from `f_j` when `f_i`'s equation is in `(M \ {f_j = 0})⁺`,
//! the part that stays over-determined once `f_j` is free (Krysander, Åslund and Nyberg). On
//! `M⁺` "not isolable from" is an equivalence relation, so the faults fall into classes, and
//! one `(M⁺ \ {e})⁺` per class finds them all: O(classes · E) after an O(E·√V) matching,
//! with no enumeration of minimal over-determined sets.

use std::collections::HashMap;

use super::component::Component;
use super::dominators;
use super::structure::{Eq, Structure, Unknown};
use crate::causality::equations::{Equation, Relation, System};
use crate::graph::{LetId, NodeId};
use crate::index::IndexVec;
use crate::symbolic::{ExprId, Leaf};

/// Faults grouped by what can tell them apart.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Classes {
    /// The detectable faults (by component index), in classes that nothing tells apart;
    /// each class in increasing order, the classes by their first member.
    pub classes: Vec<Vec<usize>>,
    /// The faults no residual can show.
    pub undetectable: Vec<usize>,
}

impl Classes {
    /// From the class of each detectable fault (`None`: undetectable), over `n` faults.
    pub(crate) fn from_labels(labels: &[Option<usize>]) -> Classes {
        let mut out = Classes::default();
        let mut index: std::collections::HashMap<usize, usize> = Default::default();
        for (i, label) in labels.iter().enumerate() {
            match label {
                None => out.undetectable.push(i),
                Some(l) => {
                    let k = *index.entry(*l).or_insert_with(|| {
                        out.classes.push(Vec::new());
                        out.classes.len() - 1
                    });
                    out.classes[k].push(i);
                }
            }
        }
        out
    }
}

/// The classes of a set of residuals, from each component's signature (the residuals it
/// shows in): with single faults, two components are told apart when their signatures differ.
pub(crate) fn of_signatures(marks: &[Vec<usize>]) -> Classes {
    let mut seen: HashMap<&[usize], usize> = HashMap::new();
    let labels: Vec<Option<usize>> = marks
        .iter()
        .map(|m| {
            if m.is_empty() {
                return None;
            }
            let next = seen.len();
            Some(*seen.entry(m.as_slice()).or_insert(next))
        })
        .collect();
    Classes::from_labels(&labels)
}

/// The structure of a model's equations with one fault equation per component, and those
/// equations, in component order.
pub(crate) fn fault_structure(system: &System, components: &[Component]) -> (Structure, Vec<Eq>) {
    let mut s = Structure::new(system.vars.len());
    let rows: Vec<Eq> = system
        .equations
        .iter()
        .map(|eq| s.push(eq.vars.iter().map(|v| Unknown(v.0)).collect()))
        .collect();
    let mut by_owner: HashMap<NodeId, Vec<usize>> = HashMap::new();
    let mut by_let: HashMap<LetId, Vec<usize>> = HashMap::new();
    for (i, eq) in system.equations.iter().enumerate() {
        by_owner.entry(eq.owner).or_default().push(i);
        for &l in &eq.lets {
            by_let.entry(l).or_default().push(i);
        }
        // A law that reads a sensor (the bench's backlash torque, computed from the
        // encoders) is wrong when that sensor is: its fault enters there too.
        for sensor in sensors_read(system, eq) {
            if sensor != eq.owner {
                by_owner.entry(sensor).or_default().push(i);
            }
        }
    }
    let none = Vec::new();
    let faults = components
        .iter()
        .map(|c| {
            let f = s.add_var();
            let owned = c.node.map_or(&none, |n| by_owner.get(&n).unwrap_or(&none));
            let modulated = c
                .modulation
                .map_or(&none, |l| by_let.get(&l).unwrap_or(&none));
            for &i in owned.iter().chain(modulated) {
                s.add_to(rows[i], f);
            }
            s.push(vec![f])
        })
        .collect();
    (s, faults)
}

/// The detectors whose readings an equation's expressions use.
pub(crate) fn sensors_read(system: &System, eq: &Equation) -> Vec<NodeId> {
    let exprs: Vec<ExprId> = match &eq.relation {
        Relation::Assign { value, .. } => vec![*value],
        Relation::Scale { k, .. } => vec![*k],
        Relation::Law { rhs, .. } => vec![*rhs],
        Relation::Sum { .. } => Vec::new(),
        Relation::Storage {
            derivative,
            integral,
            implicit,
        } => (derivative.iter().chain(integral).chain(implicit))
            .map(|d| d.1)
            .collect(),
    };
    let mut out: Vec<NodeId> = exprs
        .into_iter()
        .flat_map(|e| system.pool.leaves(e))
        .filter_map(|leaf| match leaf {
            Leaf::Sensor(node, _) => Some(node),
            _ => None,
        })
        .collect();
    out.sort();
    out.dedup();
    out
}

/// The classes every residual the equations allow can reach together.
pub(crate) fn structural(system: &System, components: &[Component]) -> Classes {
    let (s, faults) = fault_structure(system, components);
    classes(&s, &faults)
}

/// For each fault of `faults`, whether a residual of the model without fault `f`'s
/// equation can show it: its equation stays in `(M \ {f})⁺`. O(E·√V).
pub(crate) fn seen_without(s: &Structure, faults: &[Eq], f: Eq) -> Vec<bool> {
    let mut active = vec![true; s.len()];
    active[f.index()] = false;
    let plus = s.overdetermined(&active, &s.matching(&active));
    faults.iter().map(|g| plus[g.index()]).collect()
}

/// The classes of the faults `faults` (one equation each) in `s`.
///
/// Removing a free equation (one the matching leaves out) needs no repair of the matching,
/// and what then falls out of `M⁺` is what that equation dominates in the alternating-path
/// graph rooted at the free equations: its class. So each round finds the classes of the
/// free equations from one dominator tree (O(E log V)), then shifts the matching along
/// disjoint alternating paths so that an unclassified fault equation becomes free, one per
/// free equation, the nearest. On a model whose redundancy is spread (a chain measured every
/// few stages), the rounds are as many as the faults near one detector, not in the model:
/// near-linear. At worst one fault per round: O(faults · E log V).
pub(crate) fn classes(s: &Structure, faults: &[Eq]) -> Classes {
    let all = vec![true; s.len()];
    let plus = s.overdetermined(&all, &s.matching(&all));
    let mut m = s.matching(&plus);
    let mut fault_of: IndexVec<Eq, Option<usize>> = IndexVec::from_elem(None, s.len());
    for (i, &f) in faults.iter().enumerate() {
        fault_of[f] = Some(i);
    }
    let mut labels: Vec<Option<usize>> = vec![None; faults.len()];
    let mut left = faults.iter().filter(|f| plus[f.index()]).count();
    let mut next_label = 0;
    while left > 0 {
        let mut graph = s.alternating(&plus, &m);
        let free: Vec<Eq> = (s.equations())
            .filter(|&e| plus[e.index()] && m.is_free(e))
            .collect();
        // A root above the free equations, past the last equation: no equation's.
        let root = graph.push(free.clone());
        let idom = dominators::immediate(&graph, root);
        let mut children: IndexVec<Eq, Vec<Eq>> = IndexVec::from_elem(Vec::new(), graph.len());
        for (v, d) in idom.iter_enumerated() {
            if let Some(d) = *d {
                children[d].push(v);
            }
        }
        for &r in &free {
            let mut class = Vec::new();
            let mut stack = vec![r];
            while let Some(v) = stack.pop() {
                if let Some(i) = fault_of[v].filter(|&i| labels[i].is_none()) {
                    class.push(i);
                }
                stack.extend(&children[v]);
            }
            if !class.is_empty() {
                left -= class.len();
                for i in class {
                    labels[i] = Some(next_label);
                }
                next_label += 1;
            }
        }
        if left == 0 {
            break;
        }
        let unclassified = |e: Eq| fault_of[e].is_some_and(|i| labels[i].is_none());
        for path in nearest(&graph, &free, unclassified) {
            m.shift(&path);
        }
    }
    Classes::from_labels(&labels)
}

/// From each of `sources`, the path to the nearest node that is `wanted`, all disjoint: the
/// paths of one breadth-first forest grown from every source at once.
fn nearest(
    graph: &IndexVec<Eq, Vec<Eq>>,
    sources: &[Eq],
    wanted: impl Fn(Eq) -> bool,
) -> Vec<Vec<Eq>> {
    let mut parent: IndexVec<Eq, Option<Eq>> = IndexVec::from_elem(None, graph.len());
    let mut source: IndexVec<Eq, Option<Eq>> = IndexVec::from_elem(None, graph.len());
    let mut queue = std::collections::VecDeque::new();
    for &r in sources {
        source[r] = Some(r);
        queue.push_back(r);
    }
    let mut served = std::collections::HashSet::new();
    let mut paths = Vec::new();
    while let Some(v) = queue.pop_front() {
        let from = source[v];
        if wanted(v) && served.insert(from) {
            let mut path = vec![v];
            let mut u = v;
            while let Some(p) = parent[u] {
                u = p;
                path.push(u);
            }
            path.reverse();
            paths.push(path);
        }
        for &w in &graph[v] {
            if source[w].is_none() {
                source[w] = from;
                parent[w] = Some(v);
                queue.push_back(w);
            }
        }
    }
    paths
}

/// The classes by one `(M⁺ \ {e})⁺` per class: O(classes · E). A second method to check
/// the first against.
#[cfg(test)]
fn classes_by_removal(s: &Structure, faults: &[Eq]) -> Classes {
    let all = vec![true; s.len()];
    let plus = s.overdetermined(&all, &s.matching(&all));
    let m = s.matching(&plus);
    let mut labels: Vec<Option<usize>> = vec![None; faults.len()];
    for (i, &f) in faults.iter().enumerate() {
        if labels[i].is_some() || !plus[f.index()] {
            continue;
        }
        let rest = s.without(&plus, &m, f);
        for (j, &g) in faults.iter().enumerate() {
            if labels[j].is_none() && plus[g.index()] && !rest[g.index()] {
                labels[j] = Some(i);
            }
        }
    }
    Classes::from_labels(&labels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::causality::{assign, Mode};
    use crate::index::Idx;
    use std::collections::{BTreeSet, HashSet};

    /// The size of a maximum matching of `set` (Kuhn's algorithm: small models only).
    fn nu(rows: &[Vec<u32>], set: &[usize]) -> usize {
        fn try_match(
            e: usize,
            rows: &[Vec<u32>],
            owner: &mut HashMap<u32, usize>,
            seen: &mut HashSet<u32>,
        ) -> bool {
            for &v in &rows[e] {
                if seen.insert(v) {
                    let free = match owner.get(&v) {
                        None => true,
                        Some(&other) => try_match(other, rows, owner, seen),
                    };
                    if free {
                        owner.insert(v, e);
                        return true;
                    }
                }
            }
            false
        }
        let mut owner = HashMap::new();
        set.iter()
            .filter(|&&e| try_match(e, rows, &mut owner, &mut HashSet::new()))
            .count()
    }

    /// `M⁺` by its definition: the equations whose removal lowers the redundancy.
    fn plus(rows: &[Vec<u32>], set: &[usize]) -> Vec<usize> {
        let whole = set.len() - nu(rows, set);
        set.iter()
            .copied()
            .filter(|&e| {
                let rest: Vec<usize> = set.iter().copied().filter(|&x| x != e).collect();
                rest.len() - nu(rows, &rest) < whole
            })
            .collect()
    }

    /// Every minimal structurally over-determined set, by descent from `M⁺`.
    fn msos(
        rows: &[Vec<u32>],
        set: &[usize],
        seen: &mut HashSet<Vec<usize>>,
        out: &mut BTreeSet<Vec<usize>>,
    ) {
        let p = plus(rows, set);
        if p.is_empty() || !seen.insert(p.clone()) {
            return;
        }
        if p.len() - nu(rows, &p) == 1 {
            out.insert(p);
            return;
        }
        for &e in &p {
            let rest: Vec<usize> = p.iter().copied().filter(|&x| x != e).collect();
            msos(rows, &rest, seen, out);
        }
    }

    /// The classes from every MSO: `i` is isolable from `j` when some MSO holds `i`'s fault
    /// equation and not `j`'s.
    fn brute_force(s: &Structure, faults: &[Eq]) -> (Classes, usize) {
        let rows: Vec<Vec<u32>> = (s.equations())
            .map(|e| s.vars(e).iter().map(|v| v.0).collect())
            .collect();
        let all: Vec<usize> = (0..rows.len()).collect();
        let mut found = BTreeSet::new();
        msos(&rows, &all, &mut HashSet::new(), &mut found);
        let holds = |m: &Vec<usize>, f: Eq| m.binary_search(&(f.index())).is_ok();
        let isolable = |i: usize, j: usize| {
            found
                .iter()
                .any(|m| holds(m, faults[i]) && !holds(m, faults[j]))
        };
        let detectable = |i: usize| found.iter().any(|m| holds(m, faults[i]));
        let mut labels: Vec<Option<usize>> = vec![None; faults.len()];
        for i in 0..faults.len() {
            if !detectable(i) {
                continue;
            }
            for j in 0..=i {
                if detectable(j) && !isolable(i, j) {
                    assert!(!isolable(j, i), "not symmetric: {i}, {j}");
                    labels[i] = labels[j].or(Some(j));
                    break;
                }
            }
        }
        (Classes::from_labels(&labels), found.len())
    }

    fn check(file: &str) -> (usize, usize) {
        let path = format!("{}/../../models/{file}", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(&path).expect("model");
        let (model, diagnostics) = crate::graph::load(&text);
        let model = model.unwrap_or_else(|| panic!("{file}: {diagnostics:?}"));
        let causal = assign(&model, Mode::Diagnosis);
        let components = super::super::component::components(&model);
        let (s, faults) = fault_structure(&causal.system, &components);
        let fast = classes(&s, &faults);
        let (slow, count) = brute_force(&s, &faults);
        assert_eq!(fast, slow, "{file}");
        assert_eq!(classes_by_removal(&s, &faults), slow, "{file}");
        (fast.classes.len(), count)
    }

    /// The bench's backlash torque is computed from the encoders: a fault of either encoder
    /// enters the two sources that read it, not only the detector's own equation.
    #[test]
    fn a_sensor_fault_enters_every_law_that_reads_the_sensor() {
        let path = format!(
            "{}/../../models/backlash_bench.bg",
            env!("CARGO_MANIFEST_DIR")
        );
        let (model, _) = crate::graph::load(&std::fs::read_to_string(path).expect("model"));
        let model = model.expect("bench");
        let causal = assign(&model, Mode::Diagnosis);
        let components = super::super::component::components(&model);
        let (s, faults) = fault_structure(&causal.system, &components);
        let row = |name: &str| components.iter().position(|c| c.name == name).expect(name);
        let fault_var = |name: &str| s.vars(faults[row(name)])[0];
        for sensor in ["y1", "y2"] {
            let mut owners: Vec<&str> = (0..causal.system.equations.len())
                .filter(|&e| s.vars(Eq::new(e)).contains(&fault_var(sensor)))
                .map(|e| model.node(causal.system.equations[e].owner).name.as_str())
                .collect();
            owners.sort();
            assert_eq!(owners, ["Wl", "Wm", sensor], "{sensor}");
        }
    }

    /// On every model small enough to enumerate its minimal over-determined sets, the classes
    /// found without enumerating them are the same.
    #[test]
    fn classes_equal_those_of_every_minimal_over_determined_set() {
        let dir = format!("{}/../../models", env!("CARGO_MANIFEST_DIR"));
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .expect("models")
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|f| f.ends_with(".bg"))
            .collect();
        files.sort();
        let mut seen = Vec::new();
        for f in &files {
            seen.push((f.clone(), check(f)));
        }
        eprintln!("{seen:#?}");
    }
}

#[cfg(test)]
mod chain {
    use super::*;
    use crate::causality::{assign, Mode};

    fn chain_classes(stages: usize, check: bool) -> Classes {
        let text = crate::generate::mass_spring_chain_varied(stages, 5);
        let (model, diagnostics) = crate::graph::load(&text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let causal = assign(&model, Mode::Diagnosis);
        let components = super::super::component::components(&model);
        let (s, faults) = fault_structure(&causal.system, &components);
        let c = classes(&s, &faults);
        if check {
            assert_eq!(c, classes_by_removal(&s, &faults), "{stages} stages");
        }
        c
    }

    /// A chain with a velocity detector every 5th mass: the classes faultdiagnosistoolbox
    /// finds by enumerating every minimal over-determined set (13, 35 and 57 at 10, 20 and
    /// 30 stages), and at 100 and 1,000 stages the same pattern: up to the last detector,
    /// each mass with its damper (on one junction), each spring and each detector is a class
    /// of its own, and what lies beyond the last detector is one.
    #[test]
    fn a_measured_chain_has_a_class_per_stage_part_between_detectors() {
        for (stages, expected) in [(10, 13), (20, 35), (30, 57), (100, 211)] {
            let c = chain_classes(stages, true);
            assert_eq!(c.classes.len(), expected, "{stages} stages");
            assert!(c.undetectable.is_empty());
        }
        assert_eq!(chain_classes(1000, false).classes.len(), 2191);
    }
}
