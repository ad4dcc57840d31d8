//! The fault signature matrix: which component's equations each ARR was derived from.

use std::collections::{BTreeSet, HashMap};

use super::arr::Diagnosis;
use super::component::{components, Component, ComponentKind};
use super::sensitivity::dependences;
use crate::graph::{BondGraph, LetId, NodeId, ParamId};
use crate::symbolic::Leaf;

/// One row of the matrix.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Row {
    /// The component.
    pub component: Component,
    /// The ARRs (by index) in which a fault of the component can show, in increasing order.
    /// Sparse, because in a large model each component shows in a few ARRs of many.
    pub marks: Vec<usize>,
    /// Detectable: some residual is sensitive.
    pub detectable: bool,
    /// Isolable: detectable, with a signature no other component has.
    pub isolable: bool,
}

/// The fault signature matrix.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Fsm {
    /// Residual names, `r1`…
    pub residuals: Vec<String>,
    /// Rows: elements in declaration order, then modulations, then detectors.
    pub rows: Vec<Row>,
    /// The classes every residual the equations allow reaches (by row).
    pub possible: super::isolability::Classes,
}

/// For each ARR of `diagnosis`, the rows of `components` whose fault it can show, in
/// increasing order; in time linear in the total size of the ARRs' cones.
pub(super) fn arr_rows(
    model: &BondGraph,
    diagnosis: &Diagnosis,
    components: &[Component],
) -> Vec<Vec<usize>> {
    arr_rows_indexed(model, diagnosis, components, &RowIndex::new(components))
}

/// The row of each component's node and `let`: built once for many derivations.
pub(crate) struct RowIndex {
    node_row: HashMap<NodeId, usize>,
    let_row: HashMap<LetId, usize>,
    /// The row of each parameter that one component alone has.
    owner: HashMap<ParamId, usize>,
}

impl RowIndex {
    /// The index of `components`.
    pub(crate) fn new(components: &[Component]) -> RowIndex {
        let mut node_row: HashMap<NodeId, usize> = HashMap::new();
        let mut let_row: HashMap<LetId, usize> = HashMap::new();
        // Each parameter's row, or `None` once a second component has it.
        let mut owners: HashMap<ParamId, Option<usize>> = HashMap::new();
        for (i, c) in components.iter().enumerate() {
            if let Some(n) = c.node {
                node_row.insert(n, i);
            }
            if let Some(l) = c.modulation {
                let_row.insert(l, i);
            }
            for &p in &c.parameters {
                owners
                    .entry(p)
                    .and_modify(|o| *o = o.filter(|&r| r == i))
                    .or_insert(Some(i));
            }
        }
        let owner = (owners.into_iter())
            .filter_map(|(p, o)| Some((p, o?)))
            .collect();
        RowIndex {
            node_row,
            let_row,
            owner,
        }
    }

    /// The row of an element's or a detector's node.
    pub(crate) fn node(&self, n: NodeId) -> Option<usize> {
        self.node_row.get(&n).copied()
    }

    /// The row of a modulation.
    pub(crate) fn modulation(&self, l: LetId) -> Option<usize> {
        self.let_row.get(&l).copied()
    }
}

/// [`arr_rows`] with the index of `components` built already.
pub(super) fn arr_rows_indexed(
    model: &BondGraph,
    diagnosis: &Diagnosis,
    components: &[Component],
    index: &RowIndex,
) -> Vec<Vec<usize>> {
    let (node_row, let_row) = (&index.node_row, &index.let_row);
    let pool = &diagnosis.causal.system.pool;
    diagnosis
        .arrs
        .iter()
        .map(|arr| {
            // What the simplified residual still contains.
            let (mut sensors, mut params) = (BTreeSet::new(), BTreeSet::new());
            // A root is an atom of the residual: what its law reads, the residual reads.
            let (mut laws, mut stack) = (BTreeSet::new(), vec![arr.expanded]);
            while let Some(e) = stack.pop() {
                for leaf in pool.leaves(e) {
                    match leaf {
                        Leaf::Sensor(s, _) => {
                            sensors.insert(s);
                        }
                        Leaf::Param(p) => {
                            params.insert(p);
                        }
                        Leaf::Root(k, _) if laws.insert(k) => {
                            if let Some(law) = diagnosis.roots.get(k.index()) {
                                stack.push(law.residual);
                            }
                        }
                        _ => {}
                    }
                }
            }
            // A component with parameters of its own is marked only where the residual
            // depends on one of them: a parameter that cancels cannot show a fault, even if
            // it is still written (a factor of both a numerator and a denominator).
            let mut depends = dependences(pool, arr.expanded, model);
            for law in laws.iter().filter_map(|&k| diagnosis.roots.get(k.index())) {
                depends.extend(dependences(pool, law.residual, model));
            }
            let survives = |c: &Component| {
                c.parameters.is_empty()
                    || c.parameters
                        .iter()
                        .any(|p| params.contains(p) && depends.contains(p))
            };
            let mut rows: BTreeSet<usize> = BTreeSet::new();
            for n in &arr.nodes {
                if let Some(&r) = node_row.get(n) {
                    if matches!(components[r].kind, ComponentKind::Element(_)) {
                        rows.insert(r);
                    }
                }
            }
            rows.extend(arr.lets.iter().filter_map(|l| let_row.get(l)));
            rows.extend(sensors.iter().filter_map(|s| node_row.get(s)));
            // A component whose own parameter (no other component's) the residual depends on
            // through another's law (the link's K inside the dead zone `w`, read where a
            // torque sensor replaces the link's own equation) shows in it too: a change of
            // that parameter moves it. A shared parameter's reach is the FSM's `shared
            // parameters`, not a row's.
            rows.extend(
                (params.iter())
                    .filter(|p| depends.contains(p))
                    .filter_map(|p| index.owner.get(p)),
            );
            rows.into_iter()
                .filter(|&r| survives(&components[r]))
                .collect()
        })
        .collect()
}

impl Fsm {
    /// The matrix of a diagnosed model, with the classes every residual of its equations
    /// could reach.
    pub(crate) fn new(model: &BondGraph, diagnosis: &Diagnosis) -> Fsm {
        let components = components(model);
        let possible = super::isolability::structural(&diagnosis.causal.system, &components);
        let mut marks: Vec<Vec<usize>> = vec![Vec::new(); components.len()];
        for (k, rows) in arr_rows(model, diagnosis, &components)
            .into_iter()
            .enumerate()
        {
            for r in rows {
                marks[r].push(k);
            }
        }
        let mut count: HashMap<&[usize], usize> = HashMap::new();
        for m in &marks {
            *count.entry(m.as_slice()).or_default() += 1;
        }
        let isolable: Vec<bool> = marks
            .iter()
            .map(|m| !m.is_empty() && count.get(m.as_slice()) == Some(&1))
            .collect();
        let rows = components
            .into_iter()
            .zip(marks)
            .zip(isolable)
            .map(|((component, marks), isolable)| Row {
                detectable: !marks.is_empty(),
                isolable,
                component,
                marks,
            })
            .collect();
        Fsm {
            residuals: (1..=diagnosis.arrs.len())
                .map(|i| format!("r{i}"))
                .collect(),
            rows,
            possible,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `let` that is a constant written apart (`let Ctank = A/(rho*g)`, `C tank =
    /// Ctank`) is the element's modulus: its parameters are the tank's and it is no row of its
    /// own. A `let` that reads a signal (the bench's backlash torque `w`) stays a modulation.
    #[test]
    fn a_constant_let_belongs_to_the_element_that_reads_it() {
        let text = "model tank\nparam A = 0.01\nparam rho = 1000\nparam g = 9.81\n\
            param R1 = 1e7\ninput Q\nlet Ctank = A/(rho*g)\nSf pump = Q\nC tank = Ctank\n\
            R valve = R1\nDe p on n\npump -> 0:n -> tank, valve\n";
        let (model, diagnostics) = crate::graph::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let rows = components(&model);
        let names: Vec<&str> = rows.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["pump", "tank", "valve", "p"]);
        let tank = &rows[1];
        let params: Vec<&str> = (tank.parameters.iter())
            .map(|p| model.params[p.index()].name.as_str())
            .collect();
        assert_eq!(params, ["A", "rho", "g"]);
        let bench = include_str!("../../../../models/backlash_bench.bg");
        let (model, _) = crate::graph::load(bench);
        let rows = components(&model.expect("the bench"));
        assert!(rows.iter().any(|c| c.name == "w" && c.modulation.is_some()));
    }
}
