//! From syntax tree to bond graph: declarations, `let`s, laws, then bonds and checks.
//!
//! Names may be used before they are declared, so declarations are collected first. Every
//! problem is reported; a graph is returned only when there is none.

use std::collections::HashSet;

use petgraph::graph::{DiGraph, NodeIndex};

use super::bonds;
use super::faults::{self, Carrier};
use super::laws::{element_law, Context, Resolver, Variability};
use super::model::{
    BondGraph, DetectorKind, ElementKind, Faults, Input, InputId, JunctionKind, Let, LetId, Node,
    NodeId, NodeKind, Param, ParamId, Signal,
};
use super::scope::{Scope, SignalSlot};
use super::validate;
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use crate::syntax::ast::{self, ElementBody, Ident, StatementKind};

/// Lowers a parsed file; `None` when any error was reported.
pub(super) fn lower(file: &ast::File, diagnostics: &mut Diagnostics) -> Option<BondGraph> {
    let mut lowerer = Lowerer {
        diagnostics,
        scope: Scope::default(),
        model: None,
        params: Vec::new(),
        inputs: Vec::new(),
        let_decls: Vec::new(),
        pending: Vec::new(),
        chains: Vec::new(),
        unknown_kinds: Vec::new(),
        used: HashSet::new(),
    };
    lowerer.declare_all(file);
    lowerer.finish()
}

/// A node whose kind is known but whose law is not yet resolved.
struct Pending<'a> {
    name: &'a Ident,
    description: Option<String>,
    what: PendingKind<'a>,
}

enum PendingKind<'a> {
    Junction(JunctionKind),
    Element(ElementKind, &'a ast::ElementDecl),
    Detector(DetectorKind, &'a ast::ElementDecl),
}

struct Lowerer<'a, 'd> {
    diagnostics: &'d mut Diagnostics,
    scope: Scope,
    model: Option<&'a Ident>,
    params: Vec<Param>,
    inputs: Vec<Input>,
    let_decls: Vec<&'a ast::LetDecl>,
    /// Nodes in creation order: the index is the future `NodeId`.
    pending: Vec<Pending<'a>>,
    chains: Vec<&'a ast::Chain>,
    /// Elements of unknown kind: their expressions are still checked for undefined names.
    unknown_kinds: Vec<&'a ast::ElementDecl>,
    used: HashSet<Signal>,
}

impl<'a> Lowerer<'a, '_> {
    fn declare_all(&mut self, file: &'a ast::File) {
        for statement in &file.statements {
            match &statement.kind {
                StatementKind::Model(name) => self.declare_model(name),
                StatementKind::Param(p) => self.declare_param(p),
                StatementKind::Input(i) => self.declare_input(i),
                StatementKind::Let(l) => self.declare_let(l),
                StatementKind::Element(e) => self.declare_element(e),
                StatementKind::Chain(c) => self.declare_junctions(c),
                StatementKind::Unparsed(u) => self.declare_unparsed(u),
            }
        }
        if self.model.is_none() {
            self.diagnostics.push(
                Diagnostic::error(Code::ModelName, Span::new(0, 0), "the model has no name")
                    .with_label("expected `model NAME` as the first statement")
                    .with_help("start the file with a line such as `model dc_motor`"),
            );
        }
    }

    /// Marks what a statement that did not parse declares, so its uses stay quiet.
    fn declare_unparsed(&mut self, unparsed: &'a ast::Unparsed) {
        for junction in &unparsed.junctions {
            self.scope.break_node(&junction.name);
        }
        let (Some(first), name) = (&unparsed.first, &unparsed.name) else {
            return;
        };
        match (first.name.as_str(), name) {
            ("model", _) => self.model = self.model.or(Some(name.as_ref().unwrap_or(first))),
            ("param" | "input" | "let", Some(name)) => self.scope.break_signal(&name.name),
            ("De" | "Df" | "Dq" | "Dp", Some(name)) => {
                self.scope.break_signal(&name.name);
                self.scope.break_node(&name.name);
            }
            (_, Some(name)) => self.scope.break_node(&name.name),
            (_, None) => {}
        }
    }

    fn declare_model(&mut self, name: &'a Ident) {
        match self.model {
            Some(first) => self.diagnostics.push(
                Diagnostic::error(Code::ModelName, name.span, "a second `model` line")
                    .with_label("expected one `model NAME` per file")
                    .with_note(first.span, "the model is named here"),
            ),
            None => self.model = Some(name),
        }
    }

    fn declare_signal(&mut self, name: &Ident, slot: SignalSlot, what: &str) -> bool {
        if name.name == "t" {
            self.diagnostics.push(
                Diagnostic::error(Code::Reserved, name.span, "`t` is reserved for time")
                    .with_label(format!("expected another name for this {what}")),
            );
            self.scope.break_signal(&name.name);
            return false;
        }
        match self.scope.declare_signal(&name.name, slot, name.span) {
            Ok(()) => true,
            Err(first) => {
                self.diagnostics.push(duplicate(name, first));
                false
            }
        }
    }

    fn declare_param(&mut self, decl: &ast::ParamDecl) {
        let id = ParamId(self.params.len() as u32);
        let value = match decl.value {
            Some((v, _)) if v.is_finite() => Some(v),
            Some((_, span)) => {
                self.diagnostics.push(
                    Diagnostic::error(Code::BadValue, span, "this value is not a finite number")
                        .with_label("expected a number that fits a 64-bit float"),
                );
                None
            }
            None => {
                self.diagnostics.push(
                    Diagnostic::error(
                        Code::MissingValue,
                        decl.name.span,
                        format!("parameter `{}` has no value", decl.name.name),
                    )
                    .with_label("expected `= NUMBER` after the name")
                    .with_help(format!("write e.g. `param {} = 1.5`", decl.name.name)),
                );
                None
            }
        };
        let uncertainty = decl
            .uncertainty
            .and_then(|(u, span)| self.uncertainty(u, span, value));
        if self.declare_signal(&decl.name, SignalSlot::Param(id), "parameter") {
            self.params.push(Param {
                name: decl.name.name.clone(),
                // Without a value an error was reported, and the graph is not used.
                value: value.unwrap_or_default(),
                unit: decl.unit.clone(),
                uncertainty,
                shared: decl.shared.is_some(),
                description: decl.description.clone(),
                span: decl.name.span,
            });
        }
    }

    /// A parameter's uncertainty as a half-width in its unit, or `None` after reporting why
    /// it makes no sense.
    fn uncertainty(&mut self, u: ast::Uncertainty, span: Span, value: Option<f64>) -> Option<f64> {
        let half_width = match u {
            ast::Uncertainty::Percent(p) => value.map(|v| v.abs() * p / 100.0),
            ast::Uncertainty::Absolute(a) => Some(a),
        }?;
        if half_width.is_finite() && half_width >= 0.0 {
            Some(half_width)
        } else {
            self.diagnostics.push(
                Diagnostic::error(
                    Code::BadValue,
                    span,
                    "an uncertainty must be a non-negative number",
                )
                .with_label("expected e.g. `+- 5%` or `+- 0.01`"),
            );
            None
        }
    }

    fn declare_input(&mut self, decl: &ast::InputDecl) {
        let id = InputId(self.inputs.len() as u32);
        if self.declare_signal(&decl.name, SignalSlot::Input(id), "input") {
            self.inputs.push(Input {
                name: decl.name.name.clone(),
                unit: decl.unit.clone(),
                description: decl.description.clone(),
                span: decl.name.span,
            });
        }
    }

    fn declare_let(&mut self, decl: &'a ast::LetDecl) {
        let id = LetId(self.let_decls.len() as u32);
        if self.declare_signal(&decl.name, SignalSlot::Let(id), "`let`") {
            self.let_decls.push(decl);
        }
    }

    fn declare_element(&mut self, decl: &'a ast::ElementDecl) {
        let id = NodeId(NodeIndex::new(self.pending.len()));
        let what = if let Some(kind) = ElementKind::from_name(&decl.kind.name) {
            PendingKind::Element(kind, decl)
        } else if let Some(kind) = DetectorKind::from_name(&decl.kind.name) {
            if !self.declare_signal(&decl.name, SignalSlot::Sensor(id), "detector") {
                self.scope.break_node(&decl.name.name);
                return;
            }
            PendingKind::Detector(kind, decl)
        } else {
            self.diagnostics.push(unknown_kind(&decl.kind));
            self.scope.break_node(&decl.name.name);
            self.unknown_kinds.push(decl);
            return;
        };
        self.push_node(&decl.name, decl.description.clone(), what);
    }

    fn declare_junctions(&mut self, chain: &'a ast::Chain) {
        self.chains.push(chain);
        for node in chain.groups.iter().flatten() {
            let Some(kind) = node.junction else { continue };
            if let super::scope::Lookup::Found((first, span)) = self.scope.node(&node.name.name) {
                let same = matches!(
                    self.pending[first.0.index()].what,
                    PendingKind::Junction(k) if k == kind
                );
                if !same {
                    self.diagnostics.push(duplicate(&node.name, span));
                }
                continue;
            }
            self.push_node(&node.name, None, PendingKind::Junction(kind));
        }
    }

    fn push_node(&mut self, name: &'a Ident, description: Option<String>, what: PendingKind<'a>) {
        let id = NodeId(NodeIndex::new(self.pending.len()));
        match self.scope.declare_node(&name.name, id, name.span) {
            Ok(()) => self.pending.push(Pending {
                name,
                description,
                what,
            }),
            Err((_, first)) => self.diagnostics.push(duplicate(name, first)),
        }
    }

    fn finish(mut self) -> Option<BondGraph> {
        let (lets, let_order, variability) = self.resolve_lets();
        self.check_unknown_kinds(&variability);
        let mut graph = DiGraph::with_capacity(self.pending.len(), self.pending.len());
        let mut attachments = Vec::new();
        // Nodes whose bond counts prove nothing: their declaration or a statement bonding
        // them had an error.
        let mut uncertain = HashSet::new();
        for pending in std::mem::take(&mut self.pending) {
            let kind = self.node_kind(&pending, &variability, &mut attachments);
            let faults = self.faults(&pending);
            let failed = kind.is_none();
            let index = graph.add_node(Node {
                name: pending.name.name.clone(),
                kind: kind.unwrap_or(NodeKind::Junction(JunctionKind::Zero)),
                faults,
                description: pending.description,
                span: pending.name.span,
            });
            if failed {
                uncertain.insert(NodeId(index));
            }
        }
        uncertain.extend(bonds::build(
            &mut graph,
            &self.chains,
            &attachments,
            &self.scope,
            self.diagnostics,
        ));
        let model = BondGraph {
            name: self.model.map(|m| m.name.clone()).unwrap_or_default(),
            params: std::mem::take(&mut self.params),
            inputs: std::mem::take(&mut self.inputs),
            lets,
            let_order,
            graph,
        };
        // Every error at once: the structure of what was declared and bonded without error
        // is checked even when other statements had errors.
        validate::structure(
            &model,
            self.model.map(|m| m.span),
            &uncertain,
            self.diagnostics,
        );
        // With errors, a declaration may look unused only because its user was rejected.
        if !self.diagnostics.has_errors() {
            self.warn_unused(&model);
        }
        (!self.diagnostics.has_errors()).then_some(model)
    }

    /// Resolves every `let`, orders them, and finds how each varies in time.
    fn resolve_lets(&mut self) -> (Vec<Let>, Vec<super::model::LetId>, Vec<Option<Variability>>) {
        let mut resolver = Resolver {
            scope: &self.scope,
            let_variability: &[],
            used: &mut self.used,
            diagnostics: self.diagnostics,
        };
        let resolved: Vec<_> = self
            .let_decls
            .iter()
            .map(|decl| resolver.expr(&decl.value, Context::Let))
            .collect();
        let order = super::lets::order(&self.let_decls, &resolved, self.diagnostics);
        let mut variability = vec![None; resolved.len()];
        for id in &order {
            variability[id.index()] = resolved[id.index()]
                .as_ref()
                .and_then(|expr| super::lets::variability(expr, &variability));
        }
        let lets = self
            .let_decls
            .iter()
            .zip(resolved)
            .map(|(decl, value)| Let {
                name: decl.name.name.clone(),
                value: value.unwrap_or(crate::expr::Expr::Num(f64::NAN)),
                span: decl.name.span,
            })
            .collect();
        (lets, order, variability)
    }

    fn check_unknown_kinds(&mut self, variability: &[Option<Variability>]) {
        let mut resolver = Resolver {
            scope: &self.scope,
            let_variability: variability,
            used: &mut self.used,
            diagnostics: self.diagnostics,
        };
        for decl in &self.unknown_kinds {
            match &decl.body {
                ElementBody::Value(x) | ElementBody::Stiffness(x) | ElementBody::Ratio(x) => {
                    resolver.expr(x, Context::Modulated);
                }
                _ => {}
            }
        }
    }

    fn node_kind(
        &mut self,
        pending: &Pending<'a>,
        variability: &[Option<Variability>],
        attachments: &mut Vec<(NodeId, &'a Ident)>,
    ) -> Option<NodeKind> {
        match pending.what {
            PendingKind::Junction(kind) => Some(NodeKind::Junction(kind)),
            PendingKind::Element(kind, decl) => {
                let mut resolver = Resolver {
                    scope: &self.scope,
                    let_variability: variability,
                    used: &mut self.used,
                    diagnostics: self.diagnostics,
                };
                element_law(kind, decl, &mut resolver).map(|law| NodeKind::Element(kind, law))
            }
            PendingKind::Detector(kind, decl) => {
                match &decl.body {
                    ElementBody::None => {}
                    ElementBody::On(junction) => {
                        if let super::scope::Lookup::Found((me, _)) =
                            self.scope.node(&pending.name.name)
                        {
                            attachments.push((me, junction));
                        }
                    }
                    _ => self.diagnostics.push(
                        Diagnostic::error(
                            Code::BadLaw,
                            decl.name.span,
                            format!("detector `{}` cannot have a law", decl.name.name),
                        )
                        .with_label("expected `on JUNCTION` or nothing after the name")
                        .with_help("a detector only reads its junction's common variable"),
                    ),
                }
                Some(NodeKind::Detector(kind))
            }
        }
    }

    /// The sensor or actuator faults a detector or a source states with `with`.
    fn faults(&mut self, pending: &Pending<'a>) -> Faults {
        let (carrier, decl) = match pending.what {
            PendingKind::Junction(_) => return Faults::default(),
            PendingKind::Detector(_, decl) => (Carrier::Sensor, decl),
            PendingKind::Element(kind, decl) if kind.is_source() => (Carrier::Actuator, decl),
            PendingKind::Element(_, decl) => (Carrier::Other, decl),
        };
        faults::resolve(
            carrier,
            &decl.name,
            &decl.faults,
            &self.scope,
            &mut self.used,
            self.diagnostics,
        )
    }

    fn warn_unused(&mut self, model: &BondGraph) {
        let unused = |signal, name: &str, span| {
            Diagnostic::warning(Code::Unused, span, format!("`{name}` is never used")).with_label(
                match signal {
                    Signal::Param(_) => "this parameter",
                    Signal::Input(_) => "this input",
                    _ => "this `let`",
                },
            )
        };
        for (i, p) in model.params.iter().enumerate() {
            let s = Signal::Param(ParamId(i as u32));
            if !self.used.contains(&s) {
                self.diagnostics.push(unused(s, &p.name, p.span));
            }
        }
        for (i, p) in model.inputs.iter().enumerate() {
            let s = Signal::Input(InputId(i as u32));
            if !self.used.contains(&s) {
                self.diagnostics.push(unused(s, &p.name, p.span));
            }
        }
        for (i, l) in model.lets.iter().enumerate() {
            let s = Signal::Let(LetId(i as u32));
            if !self.used.contains(&s) {
                self.diagnostics.push(unused(s, &l.name, l.span));
            }
        }
    }
}

/// A name declared twice in one namespace.
pub(crate) fn duplicate(name: &Ident, first: Span) -> Diagnostic {
    Diagnostic::error(
        Code::Duplicate,
        name.span,
        format!("`{}` is declared twice", name.name),
    )
    .with_label("expected a new name")
    .with_note(first, "first declared here")
}

fn unknown_kind(kind: &Ident) -> Diagnostic {
    let mut names: Vec<&str> = ElementKind::ALL.iter().map(|k| k.name()).collect();
    names.extend(DetectorKind::ALL.iter().map(|k| k.name()));
    let d = Diagnostic::error(
        Code::UnknownKind,
        kind.span,
        format!("`{}` is not an element kind", kind.name),
    )
    .with_label(format!("expected one of {}", names.join(" ")));
    match super::scope::closest(&kind.name, names.iter().copied()) {
        Some(near) => d.with_help(format!("did you mean `{near}`?")),
        None => d.with_help("a statement starts with a keyword (model param input let), an element kind, or is a chain of bonds `a -> b`"),
    }
}

/// Parses, lowers and validates a model; the graph is `None` when any error was found.
/// Diagnostics (warnings too) come sorted by position.
pub(crate) fn load(text: &str) -> (Option<BondGraph>, Diagnostics) {
    let (file, mut diagnostics) = crate::syntax::parse(text);
    let graph = lower(&file, &mut diagnostics);
    diagnostics.sort();
    let graph = graph.filter(|_| !diagnostics.has_errors());
    (graph, diagnostics)
}
