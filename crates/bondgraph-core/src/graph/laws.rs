//! Names in expressions resolved to signals, and element bodies turned into laws.
//!
//! Where an expression stands decides what it may use: a TF modulus must be constant, a fixed
//! source may follow inputs and time but not measurements, an `R` law may use its own port
//! variable. Each rule is checked here, at the name that breaks it.

use std::collections::HashSet;

use super::model::{ElementKind, Law, PortVar, Signal, SignalExpr};
use super::scope::{Lookup, Scope, SignalSlot};
use crate::diagnostic::{Code, Diagnostic, Diagnostics};
use crate::expr::{BinOp, Expr};
use crate::syntax::ast::{AstExpr, ElementBody, ElementDecl, Ident};

/// How a signal varies in time, from least to most: what a context may accept is a ceiling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Variability {
    /// Parameters and numbers.
    Constant,
    /// Inputs and time: known in advance.
    Known,
    /// Detector outputs: known only once measured.
    Measured,
}

/// Where an expression stands, which sets what it may use.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Context<'k> {
    /// A `let`: anything but port variables.
    Let,
    /// A modulated source or two-port: anything but port variables.
    Modulated,
    /// A fixed source (`Se`, `Sf`): parameters, inputs, `t`.
    Source(ElementKind),
    /// A constant modulus or coefficient: parameters and numbers.
    Constant(ElementKind, &'k str),
    /// An explicit law `output = f(input)` of a one-port (which may read inputs and
    /// measured signals too when the element is modulated).
    Law {
        kind: ElementKind,
        output: PortVar,
        input: PortVar,
    },
}

impl Context<'_> {
    fn ceiling(self) -> Variability {
        match self {
            Context::Let | Context::Modulated => Variability::Measured,
            Context::Source(_) => Variability::Known,
            Context::Law { kind, .. } if kind.is_modulated() => Variability::Measured,
            Context::Constant(..) | Context::Law { .. } => Variability::Constant,
        }
    }
}

/// Resolves names against a scope, recording errors and which signals are used.
pub(crate) struct Resolver<'a> {
    pub scope: &'a Scope,
    /// Variability of each `let`, `None` while unknown or when its definition is broken.
    pub let_variability: &'a [Option<Variability>],
    pub used: &'a mut HashSet<Signal>,
    pub diagnostics: &'a mut Diagnostics,
}

impl Resolver<'_> {
    /// The expression with names resolved, or `None` after reporting every bad name in it.
    pub(super) fn expr(&mut self, expr: &AstExpr, context: Context<'_>) -> Option<SignalExpr> {
        let mut ok = true;
        expr.for_each_leaf(&mut |ident| ok &= self.leaf(ident, context, true).is_some());
        if !ok {
            return None;
        }
        expr.try_map(&mut |ident| self.leaf(ident, context, false).ok_or(()))
            .ok()
    }

    fn leaf(&mut self, ident: &Ident, context: Context<'_>, report: bool) -> Option<Signal> {
        if let Context::Law {
            kind,
            output,
            input,
        } = context
        {
            // A port-variable name that is not this element's (`p` in a C's law) may name a
            // signal of the model; the law's own output never can.
            let declared = !matches!(self.scope.signal(&ident.name), Lookup::Missing);
            if let Some(var) =
                PortVar::from_name(&ident.name).filter(|v| *v == output || *v == input || !declared)
            {
                if var == input {
                    return Some(Signal::Port(var));
                }
                if report {
                    self.diagnostics.push(
                        Diagnostic::error(
                            Code::BadReference,
                            ident.span,
                            format!(
                                "this law of {} gives `{}` from `{}`, so `{}` cannot appear on the right",
                                kind.name(),
                                output.name(),
                                input.name(),
                                var.name()
                            ),
                        )
                        .with_label(format!("expected an expression in `{}` and parameters", input.name())),
                    );
                }
                return None;
            }
        }
        let (signal, variability) = self.lookup(ident, report)??;
        if report {
            self.used.insert(signal);
            if variability > context.ceiling() {
                self.diagnostics
                    .push(misplaced(ident, signal, variability, context));
                return None;
            }
        } else if variability > context.ceiling() {
            return None;
        }
        Some(signal)
    }

    /// `Some(Some(..))`: found; `Some(None)`: quietly broken; `None`: missing (reported).
    fn lookup(&mut self, ident: &Ident, report: bool) -> Option<Option<(Signal, Variability)>> {
        if ident.name == "t" {
            return Some(Some((Signal::Time, Variability::Known)));
        }
        match self.scope.signal(&ident.name) {
            Lookup::Found((slot, _)) => Some(self.classify(slot)),
            Lookup::Broken => Some(None),
            Lookup::Missing => {
                if report {
                    self.diagnostics.push(undefined_signal(self.scope, ident));
                }
                None
            }
        }
    }

    fn classify(&self, slot: SignalSlot) -> Option<(Signal, Variability)> {
        Some(match slot {
            SignalSlot::Param(id) => (Signal::Param(id), Variability::Constant),
            SignalSlot::Input(id) => (Signal::Input(id), Variability::Known),
            SignalSlot::Sensor(id) => (Signal::Sensor(id), Variability::Measured),
            SignalSlot::Let(id) => {
                let variability = match self.let_variability.get(id.index()) {
                    Some(Some(v)) => *v,
                    // While the lets themselves are being resolved, any let is acceptable.
                    _ if self.let_variability.is_empty() => Variability::Constant,
                    _ => return None,
                };
                (Signal::Let(id), variability)
            }
        })
    }
}

fn undefined_signal(scope: &Scope, ident: &Ident) -> Diagnostic {
    let d = Diagnostic::error(
        Code::Undefined,
        ident.span,
        format!("`{}` is not defined", ident.name),
    )
    .with_label("expected a parameter, input, `let`, detector or `t`");
    match scope.similar_signal(&ident.name) {
        Some(near) => d.with_help(format!("did you mean `{near}`?")),
        None => d.with_help(format!(
            "declare it, e.g. `param {} = 1` or `input {}`",
            ident.name, ident.name
        )),
    }
}

fn misplaced(
    ident: &Ident,
    signal: Signal,
    variability: Variability,
    context: Context<'_>,
) -> Diagnostic {
    let what = match (signal, variability) {
        (Signal::Input(_), _) => "an input",
        (Signal::Time, _) => "time",
        (Signal::Sensor(_), _) => "a measured signal",
        (_, Variability::Known) => "a `let` that varies with inputs or time",
        _ => "a `let` that uses measured signals",
    };
    let d = Diagnostic::error(
        Code::BadReference,
        ident.span,
        format!("`{}` is {what}, which cannot appear here", ident.name),
    );
    match context {
        Context::Source(kind) => d
            .with_label("expected parameters, inputs or `t`")
            .with_help(format!(
            "a source driven by measured signals is a modulated source: write M{} instead of {}",
            kind.name(),
            kind.name()
        )),
        Context::Constant(kind, role) => {
            let d = d.with_label(format!("the {role} of {} must be constant", kind.name()));
            match kind {
                ElementKind::TF | ElementKind::GY => d.with_help(format!(
                    "a modulus that varies is a modulated element: write M{} instead of {}",
                    kind.name(),
                    kind.name()
                )),
                _ => d.with_help("use parameters and numbers only"),
            }
        }
        Context::Law { kind, input, .. } => d
            .with_label(format!(
                "expected an expression in `{}` and parameters",
                input.name()
            ))
            .with_help(format!(
                "a law that follows inputs or measured signals is a modulated element: write M{} instead of {}",
                kind.name(),
                kind.name()
            )),
        Context::Let | Context::Modulated => d,
    }
}

/// The law of an element from its declaration, or `None` after reporting why not.
pub(crate) fn element_law(
    kind: ElementKind,
    decl: &ElementDecl,
    resolver: &mut Resolver<'_>,
) -> Option<Law> {
    use ElementKind as K;
    let constant = |role| Context::Constant(kind, role);
    match (&decl.body, kind) {
        (ElementBody::Value(x), K::Se | K::Sf) => {
            resolver.expr(x, Context::Source(kind)).map(Law::Source)
        }
        (ElementBody::Value(x), K::MSe | K::MSf) => {
            resolver.expr(x, Context::Modulated).map(Law::Source)
        }
        (ElementBody::Value(x), K::MTF | K::MGY) => {
            resolver.expr(x, Context::Modulated).map(Law::Modulus)
        }
        (ElementBody::Value(x), K::TF | K::GY) => {
            resolver.expr(x, constant("modulus")).map(Law::Modulus)
        }
        (ElementBody::Ratio(n), K::TF) => resolver
            .expr(n, constant("ratio"))
            .map(|n| Law::Modulus(reciprocal(n))),
        (ElementBody::Value(x), K::R) => resolver.expr(x, constant("resistance")).map(Law::Linear),
        (ElementBody::Value(x), K::C) => resolver
            .expr(x, constant("capacitance"))
            .map(|c| Law::Linear(reciprocal(c))),
        (ElementBody::Stiffness(k), K::C) => {
            resolver.expr(k, constant("stiffness")).map(Law::Linear)
        }
        (ElementBody::Value(x), K::I) => resolver
            .expr(x, constant("inertia"))
            .map(|m| Law::Linear(reciprocal(m))),
        (ElementBody::Value(x), K::MR) => resolver.expr(x, Context::Modulated).map(Law::Linear),
        (ElementBody::Value(x), K::MC | K::MI) => resolver
            .expr(x, Context::Modulated)
            .map(|c| Law::Linear(reciprocal(c))),
        (ElementBody::Stiffness(k), K::MC) => resolver.expr(k, Context::Modulated).map(Law::Linear),
        (ElementBody::Law(var, rhs), K::R | K::C | K::I | K::MR | K::MC | K::MI) => {
            explicit_law(kind, var, rhs, resolver)
        }
        (ElementBody::None, _) => {
            resolver.diagnostics.push(missing_law(kind, decl));
            None
        }
        _ => {
            resolver.diagnostics.push(wrong_body(kind, decl));
            None
        }
    }
}

fn explicit_law(
    kind: ElementKind,
    var: &Ident,
    rhs: &AstExpr,
    resolver: &mut Resolver<'_>,
) -> Option<Law> {
    let pairs: &[(PortVar, PortVar)] = match kind.base() {
        ElementKind::R => &[(PortVar::E, PortVar::F), (PortVar::F, PortVar::E)],
        ElementKind::C => &[(PortVar::E, PortVar::Q), (PortVar::Q, PortVar::E)],
        _ => &[(PortVar::F, PortVar::P), (PortVar::P, PortVar::F)],
    };
    let found =
        PortVar::from_name(&var.name).and_then(|v| pairs.iter().find(|(output, _)| *output == v));
    let Some(&(output, input)) = found else {
        let allowed: Vec<String> = pairs
            .iter()
            .map(|(o, i)| format!("`{}` (from `{}`)", o.name(), i.name()))
            .collect();
        resolver.diagnostics.push(
            Diagnostic::error(
                Code::BadLaw,
                var.span,
                format!("a law of {} cannot define `{}`", kind.name(), var.name),
            )
            .with_label(format!("expected {}", allowed.join(" or "))),
        );
        return None;
    };
    let rhs = resolver.expr(
        rhs,
        Context::Law {
            kind,
            output,
            input,
        },
    )?;
    Some(Law::Explicit { output, rhs })
}

fn reciprocal(x: SignalExpr) -> SignalExpr {
    Expr::binary(BinOp::Div, Expr::Num(1.0), x)
}

/// What each kind accepts after its name, for messages.
pub(crate) fn accepted_bodies(kind: ElementKind) -> &'static str {
    match kind {
        ElementKind::Se | ElementKind::Sf => "`= EXPR` in parameters, inputs and `t`",
        ElementKind::MSe | ElementKind::MSf => "`= EXPR`",
        ElementKind::R => "`= RESISTANCE`, `: e = EXPR(f)` or `: f = EXPR(e)`",
        ElementKind::C => "`= CAPACITANCE`, `stiffness K`, `: e = EXPR(q)` or `: q = EXPR(e)`",
        ElementKind::I => "`= INERTIA`, `: f = EXPR(p)` or `: p = EXPR(f)`",
        ElementKind::TF => "`= MODULUS` or `ratio N`",
        ElementKind::GY => "`= MODULUS`",
        ElementKind::MTF | ElementKind::MGY => "`= EXPR`",
        ElementKind::MR => "`= EXPR`, `: e = EXPR(f)` or `: f = EXPR(e)`",
        ElementKind::MC => "`= EXPR`, `stiffness EXPR`, `: e = EXPR(q)` or `: q = EXPR(e)`",
        ElementKind::MI => "`= EXPR`, `: f = EXPR(p)` or `: p = EXPR(f)`",
    }
}

fn missing_law(kind: ElementKind, decl: &ElementDecl) -> Diagnostic {
    let what = if kind.is_source() { "value" } else { "law" };
    Diagnostic::error(
        Code::MissingValue,
        decl.name.span,
        format!("{} `{}` has no {what}", kind.name(), decl.name.name),
    )
    .with_label(format!("expected {} after the name", accepted_bodies(kind)))
}

fn wrong_body(kind: ElementKind, decl: &ElementDecl) -> Diagnostic {
    Diagnostic::error(
        Code::BadLaw,
        decl.name.span,
        format!(
            "{} `{}` cannot be declared this way",
            kind.name(),
            decl.name.name
        ),
    )
    .with_label(format!("expected {}", accepted_bodies(kind)))
}
