//! From what the stages derived to the product: names resolved once, expressions copied into
//! one pool of final names, and anything implausible refused with a diagnostic.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use super::*;
use crate::causality::equations::{Inversion, ARGUMENT};
use crate::causality::{self, Causal, Strong};
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Severity};
use crate::fdi;
use crate::fdi::candidates::{Candidate, Origin};
use crate::graph::{BondGraph, BondKind, DetectorKind, ElementKind, NodeId, NodeKind, PortVar};
use crate::pipeline::{Analysis, Diagnosed};
use crate::symbolic::{AuxIx, Leaf, Node, Pool, Printer, RootIx, VarId};

/// Why an expression cannot enter the product.
#[derive(Clone, Copy)]
enum Refusal {
    /// It still holds a solver unknown.
    Unknown,
    /// It holds a measured signal where only states and inputs may appear.
    Sensor,
    /// It holds a number that is not finite.
    NotFinite,
    /// Written out as a tree, it would pass [`MAX_PRINTED`] nodes.
    TooLarge,
}

/// Most nodes an expression may have once written out as the tree every emitter prints: a
/// DAG with much sharing (derivatives of deep nests) can stand for a tree that no one can
/// read, and that takes minutes to write.
const MAX_PRINTED: u64 = 2_000_000;

/// Builds the product of a valid model. `analysis` is `None` when only the model was asked
/// for (`bgc check`).
/// Whether a law or a `let` of `model` reads `t` (the drifts of its sensors aside).
fn reads_time(model: &BondGraph) -> bool {
    let mut reads = false;
    let mut look = |e: &crate::graph::SignalExpr| {
        e.for_each_leaf(&mut |s| reads |= matches!(s, crate::graph::Signal::Time));
    };
    for l in &model.lets {
        look(&l.value);
    }
    for id in model.nodes() {
        if let NodeKind::Element(_, law) = &model.node(id).kind {
            look(law.expr());
        }
    }
    reads
}

pub(crate) fn build(
    model: &BondGraph,
    analysis: Option<&Analysis<'_>>,
    source: &str,
    file_name: &str,
    mut diagnostics: Diagnostics,
) -> Compiled {
    let mut b = Builder::new(model);
    let mut c = Compiled {
        name: model.name.clone(),
        file_name: file_name.to_string(),
        parameters: b.parameters(),
        inputs: b.inputs(),
        sensors: b.sensors(),
        states: Arena::default(),
        exprs: Pool::default(),
        state_space: None,
        arrs: Vec::new(),
        auxiliaries: Arena::default(),
        roots: Arena::default(),
        diagnosed: false,
        reads_time: reads_time(model),
        components: Arena::default(),
        isolability: Isolability::default(),
        causality: Vec::new(),
        graph: Graph::default(),
        diagnostics: Diagnostics::default(),
        state_errors: 0,
        lines: LineIndex::new(source),
        source: source.to_string(),
    };
    c.graph = graph(model, analysis.map(|a| &a.integral));
    if let Some(a) = analysis {
        let mut stage = Diagnostics::default();
        for d in &a.state.problems {
            stage.push(d.clone());
        }
        c.causality.push(report(
            model,
            &a.integral,
            Mode::Simulation,
            &a.state.problems,
        ));
        b.state_space(&mut c, a, &mut stage);
        let of_state_equations: Vec<Diagnostic> = stage.iter().cloned().collect();
        if let Some(dd) = &a.diagnosis {
            let d = dd.base();
            for p in &d.problems {
                stage.push(p.clone());
            }
            c.causality
                .push(report(model, &d.causal, Mode::Diagnosis, &d.problems));
            b.arrs(&mut c, dd, &mut stage);
            super::uncertainty::sensitivities(&mut c);
            c.diagnosed = true;
        }
        for d in dedup(stage) {
            c.state_errors += usize::from(d.is_error() && of_state_equations.contains(&d));
            diagnostics.push(d);
        }
    }
    diagnostics.sort();
    c.diagnostics = diagnostics;
    c
}

/// Each diagnostic once: the same refusal is met in both causalities.
fn dedup(stage: Diagnostics) -> Vec<Diagnostic> {
    let mut out: Vec<Diagnostic> = Vec::new();
    for d in stage {
        if !out
            .iter()
            .any(|o| o.message == d.message && o.span == d.span)
        {
            out.push(d);
        }
    }
    out
}

/// The model's names, resolved once into product handles.
struct Builder<'m> {
    model: &'m BondGraph,
    sensor_of: HashMap<NodeId, Handle<Sensor>>,
    /// The auxiliary signals copied so far, by their index in the diagnosis, or why one
    /// could not be.
    auxiliary_of: HashMap<AuxIx, Result<Handle<Auxiliary>, Refusal>>,
    /// The unknowns of nonlinear algebraic loops, by their symbol in the state equations.
    loop_of: HashMap<VarId, Handle<LoopUnknown>>,
    /// The roots copied so far, by their index in the diagnosis, or why one could not be.
    root_of: HashMap<RootIx, Result<Handle<Root>, Refusal>>,
    /// Every name the model gives, once an auxiliary signal needs a name apart from them.
    taken: Option<BTreeSet<String>>,
    /// The number of the last auxiliary signal named (`z1`, `z2`…).
    numbered: usize,
}

impl<'m> Builder<'m> {
    fn new(model: &'m BondGraph) -> Self {
        Builder {
            model,
            sensor_of: HashMap::new(),
            auxiliary_of: HashMap::new(),
            loop_of: HashMap::new(),
            root_of: HashMap::new(),
            taken: None,
            numbered: 0,
        }
    }

    /// Names for the loops' unknowns, apart from the model's names and from each other.
    fn loop_names(&self, c: &Compiled, loops: &[crate::state_space::LoopUnknown]) -> Vec<String> {
        let mut taken = model_names(self.model);
        taken.extend(c.states.iter().map(|(_, s)| s.name.clone()));
        loops
            .iter()
            .map(|l| {
                let mut name = l.name.clone();
                while taken.contains(&name) {
                    name.push('_');
                }
                taken.insert(name.clone());
                name
            })
            .collect()
    }

    fn parameters(&self) -> Arena<Parameter> {
        let mut carried = vec![None; self.model.params.len()];
        for id in self.model.nodes() {
            let node = self.model.node(id);
            let sensor = matches!(node.kind, NodeKind::Detector(_));
            for &(fault, p) in &node.faults.0 {
                carried[p.index()] = Some(CarriedFault {
                    fault,
                    by: node.name.clone(),
                    sensor,
                });
            }
        }
        let mut out = Arena::default();
        for (p, carried) in self.model.params.iter().zip(carried) {
            out.push(Parameter {
                name: p.name.clone(),
                value: p.value,
                unit: p.unit.clone(),
                uncertainty: p.uncertainty,
                shared: p.shared,
                carried,
                description: p.description.clone(),
                span: p.span,
            });
        }
        out
    }

    fn inputs(&self) -> Arena<Input> {
        let mut out = Arena::default();
        for u in &self.model.inputs {
            out.push(Input {
                name: u.name.clone(),
                unit: u.unit.clone(),
                description: u.description.clone(),
                span: u.span,
            });
        }
        out
    }

    fn sensors(&mut self) -> Arena<Sensor> {
        let m = self.model;
        let mut out = Arena::default();
        for id in m.nodes() {
            let node = m.node(id);
            if let NodeKind::Detector(kind) = node.kind {
                let h = out.push(Sensor {
                    name: node.name.clone(),
                    kind: sensor_kind(kind),
                    junction: m
                        .detector_junction(id)
                        .map_or_else(String::new, |j| m.node(j).name.clone()),
                    description: node.description.clone(),
                    span: node.span,
                });
                self.sensor_of.insert(id, h);
            }
        }
        out
    }

    /// Copies `root` of a stage's pool into the product; `states` says whether state leaves
    /// (and not measured signals) may appear.
    fn import(
        &self,
        exprs: &mut Exprs,
        pool: &Pool,
        root: crate::symbolic::ExprId,
        reading: Reading,
    ) -> Result<Expr, Refusal> {
        let states = reading == Reading::States;
        let e = exprs.try_import(pool, root, &mut |p, leaf| {
            let symbol = match leaf {
                Leaf::Param(k) => Symbol::Parameter(Handle::new(k.index())),
                Leaf::Input(u, n) => Symbol::Input(Handle::new(u.index()), n),
                Leaf::Sensor(s, n) if !states => {
                    Symbol::Sensor(*self.sensor_of.get(&s).ok_or(Refusal::Unknown)?, n)
                }
                Leaf::Sensor(..) => return Err(Refusal::Sensor),
                Leaf::State(k) if states => Symbol::State(Handle::new(k.index())),
                Leaf::State(k) => match reading {
                    Reading::Copy(base) => Symbol::State(Handle::new(base + k.index())),
                    _ => return Err(Refusal::Unknown),
                },
                Leaf::Aux(k, n) if reading == Reading::Arr => match self.auxiliary_of.get(&k) {
                    Some(Ok(h)) => Symbol::Auxiliary(*h, n),
                    Some(Err(why)) => return Err(*why),
                    None => return Err(Refusal::Unknown),
                },
                Leaf::Time => Symbol::Time,
                Leaf::Var(v) if states => {
                    Symbol::Loop(*self.loop_of.get(&v).ok_or(Refusal::Unknown)?)
                }
                Leaf::Root(k, n) if reading == Reading::Arr => match self.root_of.get(&k) {
                    Some(Ok(h)) => Symbol::Root(*h, n),
                    Some(Err(why)) => return Err(*why),
                    None => return Err(Refusal::Unknown),
                },
                Leaf::Var(_) | Leaf::Tear(..) | Leaf::Aux(..) | Leaf::Root(..) => {
                    return Err(Refusal::Unknown)
                }
            };
            Ok(p.leaf(symbol))
        })?;
        let mut finite = true;
        let mut printed: HashMap<Expr, u64> = HashMap::new();
        exprs.visit_reachable(&[e], |id, node| {
            if let Node::Num(bits) = node {
                finite &= f64::from_bits(bits).is_finite();
            }
            let size = crate::symbolic::children(node)
                .map(|c| printed.get(&c).copied().unwrap_or(0))
                .fold(1u64, u64::saturating_add);
            printed.insert(id, size);
        });
        if !finite {
            Err(Refusal::NotFinite)
        } else if printed.get(&e).copied().unwrap_or(0) > MAX_PRINTED {
            Err(Refusal::TooLarge)
        } else {
            Ok(e)
        }
    }

    /// The state equations, all or none: a model whose state equations are incomplete gets
    /// none, with the reasons in the diagnostics.
    fn state_space(&mut self, c: &mut Compiled, a: &Analysis<'_>, stage: &mut Diagnostics) {
        let m = self.model;
        self.loop_of = (a.state.implicit.iter().enumerate())
            .map(|(k, l)| (l.var, Handle::new(k)))
            .collect();
        for s in &a.state.states {
            c.states.push(State {
                name: s.name.clone(),
                element: m.node(s.element).name.clone(),
                kind: state_kind(m, s),
                copy: None,
            });
        }
        let stage_failed = a.state.problems.iter().any(Diagnostic::is_error);
        let mut space = StateSpace {
            equations: Vec::new(),
            outputs: Vec::new(),
            loops: Vec::new(),
            copies: Vec::new(),
        };
        let mut refused: Vec<(String, NodeId, Refusal)> = Vec::new();
        let names = self.loop_names(c, &a.state.implicit);
        for (l, name) in a.state.implicit.iter().zip(names) {
            match self.import(&mut c.exprs, &a.state.pool, l.residual, Reading::States) {
                Ok(residual) => space.loops.push(LoopUnknown {
                    name,
                    description: l.description.clone(),
                    element: m.node(l.element).name.clone(),
                    residual,
                }),
                Err(r) => refused.push((format!("the loop equation of {name}"), l.element, r)),
            }
        }
        for (k, s) in a.state.states.iter().enumerate() {
            match self.import(&mut c.exprs, &a.state.pool, s.rhs, Reading::States) {
                Ok(e) => space.equations.push((Handle::new(k), e)),
                Err(r) => refused.push((format!("der({})", s.name), s.element, r)),
            }
        }
        for (sensor, e) in &a.state.outputs {
            match self.import(&mut c.exprs, &a.state.pool, *e, Reading::States) {
                Ok(e) => space.outputs.push((self.sensor_of[sensor], e)),
                Err(r) => {
                    refused.push((format!("the output {}", m.node(*sensor).name), *sensor, r))
                }
            }
        }
        if refused.is_empty() && !stage_failed {
            c.state_space = Some(space);
            return;
        }
        if !stage_failed {
            // The stages said nothing, yet an expression is implausible: say so, never print it.
            for (what, node, why) in refused {
                stage.push(refusal(m, &what, node, why));
            }
        }
    }

    /// Copies the auxiliary signals the ARRs `picked` of `d` read, each after those it reads,
    /// named `z1`, `z2`… in that order, apart from every name of the model and every
    /// auxiliary signal already copied.
    fn auxiliaries(&mut self, c: &mut Compiled, d: &fdi::Diagnosis, picked: &[usize]) {
        self.auxiliary_of.clear();
        let pool = &d.causal.system.pool;
        let roots: Vec<_> = picked.iter().map(|&k| d.arrs[k].residual).collect();
        let mut used = BTreeSet::new();
        let mut stack: Vec<AuxIx> = aux_leaves(pool, &roots);
        while let Some(k) = stack.pop() {
            if let Some(aux) = d.auxiliaries.get(k.index()) {
                if used.insert(k) {
                    stack.extend(aux_leaves(pool, &aux.derivatives));
                }
            }
        }
        if used.is_empty() {
            return;
        }
        // The model's names, once: derivation after derivation, a large model's parts each
        // name a few auxiliary signals.
        let model = self.model;
        let taken = self.taken.take().unwrap_or_else(|| model_names(model));
        for k in used {
            let aux = &d.auxiliaries[k.index()];
            let derivatives: Result<Vec<Expr>, Refusal> = aux
                .derivatives
                .iter()
                .map(|&e| self.import(&mut c.exprs, pool, e, Reading::Arr))
                .collect();
            let result = derivatives.map(|derivatives| {
                let name = loop {
                    self.numbered += 1;
                    let name = format!("z{}", self.numbered);
                    if !taken.contains(&name) {
                        break name;
                    }
                };
                c.auxiliaries.push(Auxiliary { name, derivatives })
            });
            self.auxiliary_of.insert(k, result);
        }
        self.taken = Some(taken);
    }

    /// Copies the roots that the ARRs `picked` of `d` read (directly, through auxiliary
    /// signals, or through other roots' laws), each after those its law reads, named after
    /// the variable it is (`q_spring`), apart from every name of the model; a root that an
    /// earlier derivation copied with the same law is that one.
    fn roots(&mut self, c: &mut Compiled, d: &fdi::Diagnosis, picked: &[usize]) {
        self.root_of.clear();
        let pool = &d.causal.system.pool;
        let mut from: Vec<_> = picked.iter().map(|&k| d.arrs[k].residual).collect();
        for &k in &aux_leaves(pool, &from) {
            from.extend(
                d.auxiliaries
                    .get(k.index())
                    .into_iter()
                    .flat_map(|a| a.derivatives.iter().copied()),
            );
        }
        let mut used = BTreeSet::new();
        let mut stack = from;
        while let Some(e) = stack.pop() {
            for leaf in pool.leaves(e) {
                if let Leaf::Root(k, _) = leaf {
                    if used.insert(k) {
                        stack.extend(d.roots.get(k.index()).map(|r| r.residual));
                    }
                }
            }
        }
        // Each root's law reads earlier roots only: in order, each finds those it reads.
        for k in used {
            let result = self.root(c, d, k);
            self.root_of.insert(k, result);
        }
    }

    /// Copies root `k` of `d`, or finds it among those copied.
    fn root(
        &mut self,
        c: &mut Compiled,
        d: &fdi::Diagnosis,
        k: RootIx,
    ) -> Result<Handle<Root>, Refusal> {
        let m = self.model;
        let (Some(law), Some(solved)) =
            (d.roots.get(k.index()), d.causal.solved.roots.get(k.index()))
        else {
            return Err(Refusal::Unknown);
        };
        let pool = &d.causal.system.pool;
        let owner = d.causal.system.equations[solved.equation].owner;
        let element = m.node(owner).name.clone();
        let letter = match (
            &m.node(owner).kind,
            d.causal.system.vars[solved.var.index()],
        ) {
            (NodeKind::Element(kind, _), _) if kind.is_storage() => {
                if kind.base() == ElementKind::I {
                    "p"
                } else {
                    "q"
                }
            }
            (_, causality::equations::Var::Effort(_)) => "e",
            _ => "f",
        };
        let name = format!("{letter}_{element}");
        let copy = |this: &mut Self, c: &mut Compiled, h: Handle<Root>| {
            this.root_of.insert(k, Ok(h));
            let residual = this.import(&mut c.exprs, pool, law.residual, Reading::Arr)?;
            let slope = this.import(&mut c.exprs, pool, law.slope, Reading::Arr)?;
            let derivatives = (law.derivatives.iter())
                .map(|&d| this.import(&mut c.exprs, pool, d, Reading::Arr))
                .collect::<Result<Vec<_>, _>>()?;
            Ok::<_, Refusal>((residual, slope, derivatives))
        };
        let same = (c.roots.iter())
            .filter(|(_, r)| r.element == element && r.name.trim_end_matches('_') == name)
            .map(|(h, r)| (h, r.residual))
            .collect::<Vec<_>>();
        for (h, residual) in same {
            let Ok((r, _, derivatives)) = copy(self, c, h) else {
                continue;
            };
            if r == residual {
                // This derivation may read more derivatives of it than the first did.
                let known = &mut c.roots.get_mut(h).derivatives;
                if derivatives.len() > known.len() {
                    *known = derivatives;
                }
                return Ok(h);
            }
        }
        let h = Handle::new(c.roots.len());
        let (residual, slope, derivatives) = copy(self, c, h)?;
        // A relation reads no state, so `q_spring` may name the root that stands for the
        // state's value where the ARR is evaluated.
        let mut taken = model_names(m);
        taken.extend(c.roots.values().map(|r| r.name.clone()));
        let mut unique = name;
        while taken.contains(&unique) {
            unique.push('_');
        }
        Ok(c.roots.push(Root {
            name: unique,
            element,
            residual,
            slope,
            derivatives,
        }))
    }

    /// The ARRs kept that could be written, and the FSM over them.
    fn arrs(&mut self, c: &mut Compiled, dd: &Diagnosed, stage: &mut Diagnostics) {
        let m = self.model;
        // The components each ARR written shows.
        let mut shown: Vec<&[usize]> = Vec::new();
        for (source, d) in dd.sources.iter().enumerate() {
            let picks: Vec<(&Candidate, usize)> = (dd.chosen.iter())
                .filter_map(|k| match k.derived() {
                    Some((s, arr)) if s == source => Some((k, arr)),
                    _ => None,
                })
                .collect();
            if picks.is_empty() {
                continue;
            }
            let indices: Vec<usize> = picks.iter().map(|k| k.1).collect();
            self.auxiliaries(c, d, &indices);
            self.roots(c, d, &indices);
            let pool = &d.causal.system.pool;
            for (pick, k) in picks {
                let arr = &d.arrs[k];
                match self.import(&mut c.exprs, pool, arr.residual, Reading::Arr) {
                    Ok(e) => {
                        shown.push(&pick.rows);
                        let (reads, integrals) = reads(&c.exprs, &c.auxiliaries, &c.roots, e);
                        c.arrs.push(Arr {
                            name: String::new(),
                            junction: m.node(arr.junction).name.clone(),
                            sensor: arr.sensor.map(|s| self.sensor_of[&s]),
                            expr: e,
                            form: ResidualForm::Relation,
                            components: Vec::new(),
                            without: pick.without.iter().map(|&r| Handle::new(r)).collect(),
                            reads,
                            integrals,
                            auxiliaries: auxiliaries_read(&c.exprs, &c.auxiliaries, e),
                            roots: c.roots_read(&[e]),
                            sensitivities: None,
                            realisation: Realisation::Direct,
                            inverted: inverted_laws(m, &d.causal, &arr.nodes),
                        });
                    }
                    Err(why) => stage.push(refusal(m, &arr.name, arr.junction, why)),
                }
            }
        }
        for pick in &dd.chosen {
            if let Origin::Simulated(k) = pick.origin {
                let arr = match dd.copies.get(k).and_then(Option::as_ref) {
                    Some(copy) => self.partial(c, &dd.simulated[k], copy),
                    None => self.simulated(c, &dd.simulated[k]),
                };
                if let Some(arr) = arr {
                    shown.push(&pick.rows);
                    c.arrs.push(arr);
                }
            }
        }
        for (i, arr) in c.arrs.iter_mut().enumerate() {
            arr.name = format!("ARR{}", i + 1);
        }
        let mut marks: Vec<Vec<usize>> = vec![Vec::new(); dd.fsm.rows.len()];
        for (k, rows) in shown.iter().enumerate() {
            for &r in rows.iter() {
                marks[r].push(k);
            }
        }
        for (row, marks) in dd.fsm.rows.iter().zip(marks) {
            let h = c.components.push(Component {
                name: row.component.name.clone(),
                kind: component_kind(row.component.kind),
                parameters: row
                    .component
                    .parameters
                    .iter()
                    .map(|p| Handle::new(p.index()))
                    .collect(),
                signals: row.component.signals.clone(),
                detectable: !marks.is_empty(),
                isolable: false,
                marks,
            });
            for &k in &c.components[h].marks.clone() {
                c.arrs[k].components.push(h);
            }
        }
        // A parameter marked `shared` is read by several components on purpose.
        for shared in c.shared_parameters() {
            if !c.parameters[shared.parameter].shared {
                stage.push(shared_parameter(c, &shared));
            }
        }
        let marks: Vec<Vec<usize>> = c.components.values().map(|r| r.marks.clone()).collect();
        let selected = fdi::isolability::of_signatures(&marks);
        // `Ib`: detectable, and no other row has the same signature.
        for class in selected.classes.iter().filter(|k| k.len() == 1) {
            c.components.get_mut(Handle::new(class[0])).isolable = true;
        }
        c.isolability = Isolability {
            selected: fault_classes(&selected),
            candidates: dd.candidates.as_ref().map(fault_classes),
            bound: dd.bound.as_ref().map(fault_classes),
            possible: fault_classes(&dd.fsm.possible),
            residuals: dd.set,
            capped: dd.capped,
            unrealised: dd
                .unrealised
                .iter()
                .map(|u| Unrealised {
                    without: u.without.iter().map(|&i| Handle::new(i)).collect(),
                    unseen: u.unseen.iter().map(|&i| Handle::new(i)).collect(),
                    cancelled: u.cancelled.iter().map(|&i| Handle::new(i)).collect(),
                    complete: u.complete,
                    reasons: u.reasons.clone(),
                })
                .collect(),
        };
    }
}

impl Builder<'_> {
    /// A detector's simulated residual, `y − ŷ`, from the product's state equations; `None`
    /// when they were not written (then no copy of the model can be run).
    fn simulated(&self, c: &mut Compiled, s: &fdi::simulated::Simulated) -> Option<Arr> {
        let space = c.state_space.as_ref()?;
        let sensor = self.sensor_of[&s.sensor];
        let output = space.outputs.iter().find(|o| o.0 == sensor)?.1;
        let rates: Vec<Expr> = space.equations.iter().map(|e| e.1).collect();
        self.compared(c, s.sensor, output, &rates)
    }

    /// A detector's residual against its partial copy, `y − ŷ`: the copy's states join
    /// [`Compiled::states`], marked as its, and its equations the state space's copies.
    /// `None` when the model's state equations were not written.
    fn partial(
        &self,
        c: &mut Compiled,
        s: &fdi::simulated::Simulated,
        copy: &fdi::partial::PartialCopy,
    ) -> Option<Arr> {
        c.state_space.as_ref()?;
        let sensor = self.sensor_of[&s.sensor];
        let base = c.states.len();
        let pool = &copy.space.pool;
        let mut equations = Vec::with_capacity(copy.space.states.len());
        for (k, st) in copy.space.states.iter().enumerate() {
            let rhs = self
                .import(&mut c.exprs, pool, st.rhs, Reading::Copy(base))
                .ok()?;
            equations.push((Handle::new(base + k), rhs));
        }
        let (_, output) = copy.space.outputs.first()?;
        let output = self
            .import(&mut c.exprs, pool, *output, Reading::Copy(base))
            .ok()?;
        for st in &copy.space.states {
            c.states.push(State {
                name: st.name.clone(),
                element: self.model.node(st.element).name.clone(),
                kind: state_kind(self.model, st),
                copy: Some(sensor),
            });
        }
        let rates: Vec<Expr> = equations.iter().map(|e| e.1).collect();
        let arr = self.compared(c, s.sensor, output, &rates)?;
        let imposed = copy.imposed.iter().map(|d| self.sensor_of[d]).collect();
        c.state_space.as_mut()?.copies.push(PartialCopy {
            sensor,
            imposed,
            equations,
            output,
        });
        Some(arr)
    }

    /// The simulated residual `y − output` of `detector`, whose copy runs the right-hand
    /// sides `rates`: it reads its detector, and what drives the copy (inputs, and for a
    /// partial copy the measurements imposed on it).
    fn compared(
        &self,
        c: &mut Compiled,
        detector: NodeId,
        output: Expr,
        rates: &[Expr],
    ) -> Option<Arr> {
        let sensor = self.sensor_of[&detector];
        let y = c.exprs.leaf(Symbol::Sensor(sensor, 0));
        let expr = c.exprs.sub(y, output);
        let (_, integrals) = reads(&c.exprs, &c.auxiliaries, &c.roots, expr);
        let driven = (rates.iter()).fold(expr, |a, &r| c.exprs.add(a, r));
        let (reads, _) = reads(&c.exprs, &c.auxiliaries, &c.roots, driven);
        let junction = self.model.detector_junction(detector)?;
        Some(Arr {
            name: String::new(),
            junction: self.model.node(junction).name.clone(),
            sensor: Some(sensor),
            expr,
            form: ResidualForm::Simulated,
            components: Vec::new(),
            without: Vec::new(),
            reads,
            integrals,
            auxiliaries: Vec::new(),
            roots: Vec::new(),
            sensitivities: None,
            realisation: Realisation::Direct,
            // The copy holds the state equations, whose inversions the simulation's
            // causality states.
            inverted: Vec::new(),
        })
    }
}

/// Which variable of its element a state is.
fn state_kind(m: &BondGraph, s: &crate::state_space::StateEquation) -> StateKind {
    let capacitor =
        matches!(&m.node(s.element).kind, NodeKind::Element(k, _) if k.base() == ElementKind::C);
    let detector = matches!(&m.node(s.element).kind, NodeKind::Detector(_));
    match (detector, capacitor, s.co_energy) {
        (true, _, _) => StateKind::Measured,
        (_, true, false) => StateKind::Displacement,
        (_, true, true) => StateKind::Effort,
        (_, _, false) => StateKind::Momentum,
        (_, _, true) => StateKind::Flow,
    }
}

/// What an imported expression is: which leaves it may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reading {
    /// An ARR's: signals and their derivatives, auxiliary signals, roots; no state.
    Arr,
    /// The state equations': states and loop unknowns, inputs; no measured signal.
    States,
    /// A partial copy's: its states (after the first `usize` of [`Compiled::states`]),
    /// inputs and measured signals.
    Copy(usize),
}

/// Component indices as handles.
fn fault_classes(c: &fdi::isolability::Classes) -> FaultClasses {
    let handles = |k: &[usize]| k.iter().map(|&i| Handle::new(i)).collect();
    FaultClasses {
        classes: c.classes.iter().map(|k| handles(k)).collect(),
        undetectable: handles(&c.undetectable),
    }
}

/// The diagnostic for an expression bgc will not print.
fn refusal(model: &BondGraph, what: &str, node: NodeId, why: Refusal) -> Diagnostic {
    let reason = match why {
        Refusal::Unknown => "it still depends on a variable that nothing known determines",
        Refusal::Sensor => "it reads a measured signal, which a state equation cannot",
        Refusal::NotFinite => {
            "it holds a number that is not finite (a division by zero in the model's values?)"
        }
        Refusal::TooLarge => "written out, it would pass bgc's bound of 2,000,000 nodes",
    };
    let code = match why {
        Refusal::TooLarge => Code::TooLarge,
        _ => Code::Refused,
    };
    causality::report::at_nodes(
        model,
        Severity::Error,
        code,
        &[node],
        format!("{what} is not written: {reason}"),
    )
}

/// The auxiliary signals (by index in the diagnosis) that `roots` read directly.
fn aux_leaves(pool: &Pool, roots: &[crate::symbolic::ExprId]) -> Vec<AuxIx> {
    let mut out = BTreeSet::new();
    for &r in roots {
        for leaf in pool.leaves(r) {
            if let Leaf::Aux(k, _) = leaf {
                out.insert(k);
            }
        }
    }
    out.into_iter().collect()
}

/// Every name the model gives: an auxiliary signal must not take one.
fn model_names(model: &BondGraph) -> BTreeSet<String> {
    let mut out: BTreeSet<String> = BTreeSet::new();
    out.extend(model.params.iter().map(|p| p.name.clone()));
    out.extend(model.inputs.iter().map(|u| u.name.clone()));
    out.extend(model.lets.iter().map(|l| l.name.clone()));
    out.extend(model.nodes().map(|n| model.node(n).name.clone()));
    out
}

/// `e`, the derivatives of auxiliary signals that it reads, and the laws of the roots it
/// reads, directly or through others.
fn with_definitions(
    exprs: &Exprs,
    auxiliaries: &Arena<Auxiliary>,
    roots: &Arena<Root>,
    e: Expr,
) -> Vec<Expr> {
    let mut out = vec![e];
    for h in super::roots_read(exprs, auxiliaries, roots, &[e]) {
        out.push(roots[h].residual);
    }
    // The derivatives of roots read, written out, read signals of their own.
    let mut derivatives: Vec<Expr> = Vec::new();
    exprs.visit_reachable(&out, |_, node| {
        if let Node::Leaf(Symbol::Root(h, n)) = node {
            derivatives.extend(roots[h].derivative(n).filter(|_| n > 0));
        }
    });
    out.extend(derivatives);
    let read = super::auxiliary_derivatives_read(exprs, auxiliaries, &out);
    out.extend(
        read.into_iter()
            .filter_map(|(a, n)| auxiliaries[a].derivative(n)),
    );
    out
}

/// The auxiliary signals `e` reads, directly or through others, in definition order.
fn auxiliaries_read(
    exprs: &Exprs,
    auxiliaries: &Arena<Auxiliary>,
    e: Expr,
) -> Vec<Handle<Auxiliary>> {
    let read = super::auxiliary_derivatives_read(exprs, auxiliaries, &[e]);
    let handles: BTreeSet<Handle<Auxiliary>> = read.into_iter().map(|(a, _)| a).collect();
    handles.into_iter().collect()
}

/// What an expression reads, through the auxiliary signals it reads too: each signal's
/// derivative orders (those read pointwise, not only under an integral) and integral, and
/// the arguments of integrals of anything else.
pub(super) fn reads(
    exprs: &Exprs,
    auxiliaries: &Arena<Auxiliary>,
    roots: &Arena<Root>,
    e: Expr,
) -> (Vec<SignalUse>, Vec<Expr>) {
    let mut uses: BTreeMap<Signal, (BTreeSet<u32>, bool)> = BTreeMap::new();
    let mut others = Vec::new();
    let roots = with_definitions(exprs, auxiliaries, roots, e);
    let mut pointwise: BTreeSet<Expr> = roots.iter().copied().collect();
    exprs.visit_reachable(&roots, |_, node| match node {
        Node::Int(arg) => match exprs.node(arg) {
            Node::Leaf(Symbol::Input(u, 0)) => uses.entry(Signal::Input(u)).or_default().1 = true,
            Node::Leaf(Symbol::Sensor(s, 0)) => uses.entry(Signal::Sensor(s)).or_default().1 = true,
            _ => {
                others.push(arg);
                pointwise.insert(arg);
            }
        },
        Node::Neg(a) | Node::Call1(_, a) => {
            pointwise.insert(a);
        }
        Node::Binary(_, a, b) | Node::Call2(_, a, b) => {
            pointwise.extend([a, b]);
        }
        Node::Num(_) | Node::Leaf(_) => {}
    });
    for &id in &pointwise {
        match exprs.node(id) {
            Node::Leaf(Symbol::Input(u, n)) => {
                uses.entry(Signal::Input(u)).or_default().0.insert(n);
            }
            Node::Leaf(Symbol::Sensor(s, n)) => {
                uses.entry(Signal::Sensor(s)).or_default().0.insert(n);
            }
            _ => {}
        }
    }
    let reads = uses
        .into_iter()
        .map(|(signal, (orders, integral))| SignalUse {
            signal,
            orders: orders.into_iter().collect(),
            integral,
        })
        .collect();
    (reads, others)
}

fn sensor_kind(kind: DetectorKind) -> SensorKind {
    match kind {
        DetectorKind::De => SensorKind::Effort,
        DetectorKind::Df => SensorKind::Flow,
        DetectorKind::Dq => SensorKind::Displacement,
        DetectorKind::Dp => SensorKind::Momentum,
    }
}

fn component_kind(kind: fdi::ComponentKind) -> ComponentKind {
    match kind {
        fdi::ComponentKind::Element(k) => ComponentKind::Element(k.name()),
        fdi::ComponentKind::Detector(k) => ComponentKind::Sensor(sensor_kind(k)),
        fdi::ComponentKind::Modulation => ComponentKind::Modulation,
    }
}

/// The warning for a parameter several components read, at its declaration.
fn shared_parameter(c: &Compiled, shared: &SharedParameter) -> Diagnostic {
    let parameter = &c.parameters[shared.parameter];
    let mut names: Vec<String> = shared
        .components
        .iter()
        .map(|&h| format!("`{}`", c.components[h].name))
        .collect();
    // At least two: the last joins with "and".
    let last = names.pop().unwrap_or_default();
    Diagnostic::warning(
        Code::SharedParameter,
        parameter.span,
        format!(
            "`{}` is a parameter of {} and {last}: a change of it is a fault of all of them at once, which their rows (one fault at a time) do not show",
            parameter.name,
            names.join(", ")
        ),
    )
    .with_label("shared here")
    .with_help("the output's `shared parameters` lists the ARRs a change of it can show in (the union of their rows); a parameter of each component's own keeps faults apart; `shared` after its value (`param N = 5 shared`) says the model means it, and silences this")
}

/// The causality of one mode in the model's names.
fn report(
    model: &BondGraph,
    causal: &Causal,
    mode: Mode,
    problems: &[Diagnostic],
) -> CausalityReport {
    let storage = causal
        .storage(model)
        .into_iter()
        .map(|(n, s)| {
            let s = match s {
                causality::StorageCausality::Integral => StorageCausality::Integral,
                causality::StorageCausality::Derivative => StorageCausality::Derivative,
                causality::StorageCausality::Unassigned => StorageCausality::Unassigned,
            };
            (model.node(n).name.clone(), s)
        })
        .collect();
    let junctions = model
        .nodes()
        .filter(|&n| model.node(n).is_junction())
        .map(|n| {
            let setter = match causal.strong_bond(model, n) {
                Some(Strong::Bond(b)) => Setter::Bond(model.bond(b).number),
                Some(Strong::Detector(d)) => Setter::Detector(model.node(d).name.clone()),
                None => Setter::Nothing,
            };
            (model.node(n).name.clone(), setter)
        })
        .collect();
    let (mut messages, mut notes): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    for p in problems {
        let list = if p.is_error() {
            &mut messages
        } else {
            &mut notes
        };
        if !list.contains(&p.message) {
            list.push(p.message.clone());
        }
    }
    CausalityReport {
        mode,
        storage,
        junctions,
        problems: messages,
        notes,
        inverted: inverted_laws(model, causal, &model.nodes().collect()),
    }
}

/// The inversions `causal` used at the elements of `nodes`: those whose element's equation
/// solves an unknown that needs them.
fn inverted_laws(model: &BondGraph, causal: &Causal, nodes: &BTreeSet<NodeId>) -> Vec<InvertedLaw> {
    let sys = &causal.system;
    let used = |inv: &Inversion| {
        sys.equations.iter().enumerate().any(|(i, eq)| {
            eq.owner == inv.element
                && matches!(causal.solved.uses[i], causality::solve::Use::Solves { var, .. } if inv.needed_for.contains(&var))
        })
    };
    let name = |leaf: Leaf, given: PortVar| match leaf {
        l if l == ARGUMENT => given.name().to_string(),
        Leaf::Param(id) => model.params[id.index()].name.clone(),
        Leaf::Input(id, _) => model.inputs[id.index()].name.clone(),
        Leaf::Sensor(id, _) => model.node(id).name.clone(),
        Leaf::Time => "t".to_string(),
        // Laws read parameters and their own port only.
        _ => "?".to_string(),
    };
    sys.inversions
        .iter()
        .filter(|inv| nodes.contains(&inv.element) && used(inv))
        .map(|inv| {
            let printer = Printer::new(&sys.pool, |l| name(l, inv.given));
            InvertedLaw {
                element: model.node(inv.element).name.clone(),
                law: format!("{} = {}", inv.solved.name(), printer.text(inv.value)),
                domain: inv
                    .domain
                    .iter()
                    .map(|c| c.bound.describe(&printer.text(c.expr)))
                    .collect(),
            }
        })
        .collect()
}

/// The bond graph for drawings, with the strokes of `causal` when it is known.
fn graph(model: &BondGraph, causal: Option<&Causal>) -> Graph {
    let mut g = Graph::default();
    let mut handle: HashMap<NodeId, Handle<GraphNode>> = HashMap::new();
    for id in model.nodes() {
        let node = model.node(id);
        let mut modulation = Vec::new();
        let (class, note) = match &node.kind {
            NodeKind::Junction(kind) => (NodeClass::Junction(kind.symbol()), String::new()),
            NodeKind::Element(kind, law) => {
                if kind.is_modulated() {
                    modulation = fdi::signal_names(model, law.expr());
                }
                (NodeClass::Element(kind.name()), model.show(law.expr()))
            }
            NodeKind::Detector(kind) => (
                NodeClass::Sensor(sensor_kind(*kind)),
                node.description.clone().unwrap_or_default(),
            ),
        };
        let h = g.nodes.push(GraphNode {
            name: node.name.clone(),
            class,
            note,
            modulation,
        });
        handle.insert(id, h);
    }
    for id in model.bonds() {
        let bond = model.bond(id);
        let (tail, head) = model.ends(id);
        let setter = causal.and_then(|c| c.effort_setter(model, id));
        let stroke = match bond.kind {
            BondKind::Signal => Stroke::None,
            BondKind::Power if setter == Some(tail) => Stroke::Head,
            BondKind::Power if setter == Some(head) => Stroke::Tail,
            BondKind::Power => Stroke::None,
        };
        g.bonds.push(GraphBond {
            number: bond.number,
            tail: handle[&tail],
            head: handle[&head],
            signal: bond.kind == BondKind::Signal,
            stroke,
        });
    }
    g
}
