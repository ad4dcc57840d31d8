//! The components that can fail: elements, modulations and detectors, each with the
//! parameters and signals that belong to it.

use std::collections::BTreeSet;

use crate::graph::{
    BondGraph, DetectorKind, ElementKind, LetId, NodeId, NodeKind, ParamId, Signal, SignalExpr,
};

/// What kind of component a row is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ComponentKind {
    /// An element (a source is an actuator).
    Element(ElementKind),
    /// A detector (a sensor).
    Detector(DetectorKind),
    /// A `let` with parameters of its own that modulates elements (the bench's backlash `w`).
    Modulation,
}

/// A component that can fail.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Component {
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

/// The parameters each `let` uses, directly or through other `let`s, computed once in
/// dependency order (so a chain of `let`s costs its length, not its length squared).
fn let_parameters(model: &BondGraph) -> Vec<BTreeSet<ParamId>> {
    let mut deep: Vec<BTreeSet<ParamId>> = vec![BTreeSet::new(); model.lets.len()];
    for &l in &model.let_order {
        let mut own = BTreeSet::new();
        params_of(&model.lets[l.index()].value, Some(&deep), &mut own);
        deep[l.index()] = own;
    }
    deep
}

/// Whether each `let` is a constant: it reads parameters and numbers only, through other
/// `let`s too (in dependency order, so each is decided after those it reads).
fn constant_lets(model: &BondGraph) -> Vec<bool> {
    let mut constant = vec![false; model.lets.len()];
    for &l in &model.let_order {
        let mut only_parameters = true;
        model.lets[l.index()]
            .value
            .for_each_leaf(&mut |s| match *s {
                Signal::Param(_) => {}
                Signal::Let(m) => only_parameters &= constant[m.index()],
                _ => only_parameters = false,
            });
        constant[l.index()] = only_parameters;
    }
    constant
}

/// The parameters `expr` names, and with `deep` those of the `let`s it uses.
fn params_of(expr: &SignalExpr, deep: Option<&[BTreeSet<ParamId>]>, out: &mut BTreeSet<ParamId>) {
    expr.for_each_leaf(&mut |s| match *s {
        Signal::Param(p) => {
            out.insert(p);
        }
        Signal::Let(l) => {
            if let Some(set) = deep.and_then(|d| d.get(l.index())) {
                out.extend(set.iter().copied());
            }
        }
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

pub(crate) fn signal_names(model: &BondGraph, expr: &SignalExpr) -> Vec<String> {
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
pub(crate) fn components(model: &BondGraph) -> Vec<Component> {
    let mut out = Vec::new();
    let mut element_params = BTreeSet::new();
    let mut modulating = BTreeSet::new();
    let deep = let_parameters(model);
    let constant = constant_lets(model);
    for id in model.nodes() {
        let node = model.node(id);
        if let NodeKind::Element(kind, law) = &node.kind {
            let (mut direct, mut all) = (BTreeSet::new(), BTreeSet::new());
            params_of(law.expr(), None, &mut direct);
            params_of(law.expr(), Some(&deep), &mut all);
            // A constant `let` the law reads is its modulus written apart (`let Ctank =
            // A/(rho*g)`, `C tank = Ctank`): its parameters are the element's.
            for l in lets_of(law.expr())
                .into_iter()
                .filter(|l| constant[l.index()])
            {
                direct.extend(deep[l.index()].iter().copied());
            }
            // A source's gain and offset (`with`) are its own, as an actuator's faults.
            direct.extend(node.faults.0.iter().map(|(_, p)| *p));
            all.extend(node.faults.0.iter().map(|(_, p)| *p));
            element_params.extend(direct.iter().copied());
            let read = deep_lets(model, law.expr()).into_iter();
            modulating.extend(read.filter(|l| !constant[l.index()]));
            let signals = if kind.is_source() || kind.is_modulated() {
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
        let value = &model.lets[l.index()].value;
        let (mut direct, mut all) = (BTreeSet::new(), BTreeSet::new());
        params_of(value, None, &mut direct);
        params_of(value, Some(&deep), &mut all);
        let own: Vec<ParamId> = direct.difference(&element_params).copied().collect();
        if own.is_empty() {
            continue;
        }
        out.push(Component {
            name: model.lets[l.index()].name.clone(),
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
            // Its bias, gain and drift (`with`): a sensor's faults as parameters.
            let own: Vec<ParamId> = node.faults.0.iter().map(|(_, p)| *p).collect();
            out.push(Component {
                name: node.name.clone(),
                kind: ComponentKind::Detector(kind),
                node: Some(id),
                modulation: None,
                parameters: own.clone(),
                all_parameters: own,
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
            stack.extend(lets_of(&model.lets[l.index()].value));
        }
    }
    out
}
