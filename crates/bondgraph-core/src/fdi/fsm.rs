//! The fault signature matrix: which component's equations each ARR was derived from.

use std::collections::BTreeSet;

use super::arr::Diagnosis;
use crate::graph::{
    BondGraph, DetectorKind, ElementKind, LetId, NodeId, NodeKind, ParamId, Signal, SignalExpr,
};
use crate::symbolic::Leaf;

/// What kind of component a row is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ComponentKind {
    /// An element (a source is an actuator).
    Element(ElementKind),
    /// A detector (a sensor).
    Detector(DetectorKind),
    /// A `let` with parameters of its own that modulates elements (the bench's backlash `w`).
    Modulation,
}

impl ComponentKind {
    /// The kind as printed: `R`, `MSe`, `Df`, `let`.
    pub fn name(self) -> &'static str {
        match self {
            ComponentKind::Element(k) => k.name(),
            ComponentKind::Detector(k) => k.name(),
            ComponentKind::Modulation => "let",
        }
    }
}

/// A component that can fail.
#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    /// Its name.
    pub name: String,
    /// What it is.
    pub kind: ComponentKind,
    /// The node, for elements and detectors.
    pub node: Option<NodeId>,
    /// The `let`, for modulations.
    pub modulation: Option<LetId>,
    /// The parameters that belong to it: those its law uses directly (for a modulation, those
    /// no element law uses directly).
    pub parameters: Vec<ParamId>,
    /// Every parameter its law depends on, through `let`s too.
    pub all_parameters: Vec<ParamId>,
    /// The signals it applies or measures: a source's inputs and `let`s, a detector's name.
    pub signals: Vec<String>,
}

/// One row of the matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The component.
    pub component: Component,
    /// One entry per ARR: whether a fault of the component can show in that residual.
    pub signature: Vec<bool>,
    /// Detectable: some residual is sensitive.
    pub detectable: bool,
    /// Isolable: detectable, with a signature no other component has.
    pub isolable: bool,
}

/// The fault signature matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct Fsm {
    /// Residual names, `r1`…
    pub residuals: Vec<String>,
    /// Rows: elements in declaration order, then modulations, then detectors.
    pub rows: Vec<Row>,
}

fn params_of(model: &BondGraph, expr: &SignalExpr, deep: bool, out: &mut BTreeSet<ParamId>) {
    expr.for_each_leaf(&mut |s| match *s {
        Signal::Param(p) => {
            out.insert(p);
        }
        Signal::Let(l) if deep => params_of(model, &model.lets[l.0 as usize].value, true, out),
        _ => {}
    });
}

fn lets_of(expr: &SignalExpr) -> BTreeSet<LetId> {
    let mut out = BTreeSet::new();
    expr.for_each_leaf(&mut |s| {
        if let Signal::Let(l) = s {
            out.insert(*l);
        }
    });
    out
}

fn signal_names(model: &BondGraph, expr: &SignalExpr) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    expr.for_each_leaf(&mut |s| {
        if matches!(
            s,
            Signal::Input(_) | Signal::Sensor(_) | Signal::Let(_) | Signal::Time
        ) {
            let name = model.signal_name(*s).to_string();
            if !out.contains(&name) {
                out.push(name);
            }
        }
    });
    out
}

/// The components of a model, in row order.
pub fn components(model: &BondGraph) -> Vec<Component> {
    let mut out = Vec::new();
    let mut element_params = BTreeSet::new();
    let mut modulating = BTreeSet::new();
    for id in model.nodes() {
        let node = model.node(id);
        if let NodeKind::Element(kind, law) = &node.kind {
            let (mut direct, mut all) = (BTreeSet::new(), BTreeSet::new());
            params_of(model, law.expr(), false, &mut direct);
            params_of(model, law.expr(), true, &mut all);
            element_params.extend(direct.iter().copied());
            modulating.extend(deep_lets(model, law.expr()));
            let signals = if kind.is_source() || matches!(kind, ElementKind::MTF | ElementKind::MGY)
            {
                signal_names(model, law.expr())
            } else {
                Vec::new()
            };
            out.push(Component {
                name: node.name.clone(),
                kind: ComponentKind::Element(*kind),
                node: Some(id),
                modulation: None,
                parameters: direct.into_iter().collect(),
                all_parameters: all.into_iter().collect(),
                signals,
            });
        }
    }
    for l in modulating {
        let value = &model.lets[l.0 as usize].value;
        let (mut direct, mut all) = (BTreeSet::new(), BTreeSet::new());
        params_of(model, value, false, &mut direct);
        params_of(model, value, true, &mut all);
        let own: Vec<ParamId> = direct.difference(&element_params).copied().collect();
        if own.is_empty() {
            continue;
        }
        out.push(Component {
            name: model.lets[l.0 as usize].name.clone(),
            kind: ComponentKind::Modulation,
            node: None,
            modulation: Some(l),
            parameters: own,
            all_parameters: all.into_iter().collect(),
            signals: signal_names(model, value),
        });
    }
    for id in model.nodes() {
        let node = model.node(id);
        if let NodeKind::Detector(kind) = node.kind {
            out.push(Component {
                name: node.name.clone(),
                kind: ComponentKind::Detector(kind),
                node: Some(id),
                modulation: None,
                parameters: Vec::new(),
                all_parameters: Vec::new(),
                signals: vec![node.name.clone()],
            });
        }
    }
    out
}

/// Every `let` an expression uses, through other `let`s too.
fn deep_lets(model: &BondGraph, expr: &SignalExpr) -> BTreeSet<LetId> {
    let mut out = BTreeSet::new();
    let mut stack: Vec<LetId> = lets_of(expr).into_iter().collect();
    while let Some(l) = stack.pop() {
        if out.insert(l) {
            stack.extend(lets_of(&model.lets[l.0 as usize].value));
        }
    }
    out
}

impl Fsm {
    /// The matrix of a diagnosed model.
    pub fn new(model: &BondGraph, diagnosis: &Diagnosis) -> Fsm {
        // What each simplified residual still contains.
        let contents: Vec<(BTreeSet<NodeId>, BTreeSet<ParamId>)> = diagnosis
            .arrs
            .iter()
            .map(|arr| {
                let (mut sensors, mut params) = (BTreeSet::new(), BTreeSet::new());
                for leaf in diagnosis.causal.system.pool.leaves(arr.residual) {
                    match leaf {
                        Leaf::Sensor(s, _) => {
                            sensors.insert(s);
                        }
                        Leaf::Param(p) => {
                            params.insert(p);
                        }
                        _ => {}
                    }
                }
                (sensors, params)
            })
            .collect();
        let mut rows: Vec<Row> = components(model)
            .into_iter()
            .map(|component| {
                let signature: Vec<bool> = diagnosis
                    .arrs
                    .iter()
                    .zip(&contents)
                    .map(|(arr, (sensors, params))| {
                        let structural =
                            match (component.kind, component.node, component.modulation) {
                                (ComponentKind::Detector(_), Some(n), _) => sensors.contains(&n),
                                (_, Some(n), _) => arr.nodes.contains(&n),
                                (_, None, Some(l)) => arr.lets.contains(&l),
                                _ => false,
                            };
                        // A component with parameters of its own is marked only where one of
                        // them survives simplification: a term that cancels cannot show a fault.
                        structural
                            && (component.parameters.is_empty()
                                || component.parameters.iter().any(|p| params.contains(p)))
                    })
                    .collect();
                let detectable = signature.iter().any(|&b| b);
                Row {
                    component,
                    signature,
                    detectable,
                    isolable: false,
                }
            })
            .collect();
        let signatures: Vec<Vec<bool>> = rows.iter().map(|r| r.signature.clone()).collect();
        for (i, row) in rows.iter_mut().enumerate() {
            let unique = signatures
                .iter()
                .enumerate()
                .all(|(j, s)| j == i || *s != row.signature);
            row.isolable = row.detectable && unique;
        }
        Fsm {
            residuals: (1..=diagnosis.arrs.len())
                .map(|i| format!("r{i}"))
                .collect(),
            rows,
        }
    }
}
