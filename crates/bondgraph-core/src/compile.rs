//! The front door: a model's text in, the product and every diagnostic out.

use crate::causality::equations::{
    first_oversized_derivative, Holder, Oversized, MOST_DERIVATIVE_NODES,
};
use crate::diagnostic::{Code, Diagnostic, Diagnostics};
use crate::display::Unsimplified;
use crate::fdi::ResidualSet;
use crate::graph::{first_too_large, load, MAX_EXPANDED};
use crate::pipeline::analyse;
use crate::product::{build, realise, Compiled};
use crate::symbolic::rewrite::Limits;

/// How far to take a model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Derive {
    /// Parse and validate only (`bgc check`): no causality, no equations.
    Nothing,
    /// The simulation causality and the state equations (`--emit state`, `--emit dot`).
    StateEquations,
    /// Both causalities, the state equations, the ARRs and the FSM.
    Everything,
}

/// What to compile and how to write expressions.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// How far to go.
    pub derive: Derive,
    /// The e-graph's limits for writing expressions; `None` keeps the canonical forms.
    pub simplify: Option<Limits>,
    /// Which residuals to derive and keep.
    pub residuals: ResidualSet,
    /// How residual generators evaluate the ARRs.
    pub realise: Realise,
}

/// How residual generators evaluate the ARRs (see [`crate::Realisation`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Realise {
    /// Each ARR that can be is integrated once, so that it reads one order of derivative
    /// fewer; the others as written.
    #[default]
    Lowest,
    /// Every ARR as written.
    Direct,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            derive: Derive::Everything,
            simplify: Some(Limits::default()),
            residuals: ResidualSet::default(),
            realise: Realise::default(),
        }
    }
}

/// The result of [`compile`] on a valid model.
#[derive(Clone, Debug)]
pub struct Output {
    /// The product; its diagnostics say what was refused, if anything.
    pub compiled: Compiled,
    /// Expressions shown in canonical form because a count limit skipped their rewriting.
    pub unsimplified: Vec<Unsimplified>,
}

/// Compiles a model's text. `Err` holds the diagnostics of a model that is not valid (syntax,
/// names, structure); a valid model gives the product, whose own diagnostics hold the
/// warnings and whatever a stage could not derive (then [`Compiled::has_errors`]).
pub fn compile(source: &str, file_name: &str, options: &Options) -> Result<Output, Diagnostics> {
    let text = without_bom(source);
    let (graph, mut diagnostics) = load(text);
    let Some(model) = graph else {
        return Err(diagnostics);
    };
    if let Some((l, size)) = first_too_large(&model).filter(|_| options.derive != Derive::Nothing) {
        let decl = &model.lets[l.index()];
        let size = if size == u64::MAX {
            "more than 10^19".to_string()
        } else {
            size.to_string()
        };
        diagnostics.push(
            Diagnostic::error(
                Code::TooLarge,
                decl.span,
                format!(
                    "`{}` is {size} nodes long once the `let`s it uses are written out, past bgc's bound of {MAX_EXPANDED}",
                    decl.name
                ),
            )
            .with_label("this definition grows too large")
            .with_help(
                "each use of a `let` copies its definition; a `let` that uses the one before it twice doubles at every step",
            ),
        );
        diagnostics.sort();
    }
    if options.derive != Derive::Nothing && !diagnostics.has_errors() {
        if let Some(o) = first_oversized_derivative(&model) {
            diagnostics.push(oversized(&model, o));
            diagnostics.sort();
        }
    }
    if options.derive == Derive::Nothing || diagnostics.has_errors() {
        let compiled = build(&model, None, text, file_name, diagnostics);
        return Ok(Output {
            compiled,
            unsimplified: Vec::new(),
        });
    }
    let mut analysis = analyse(
        &model,
        options.derive == Derive::Everything,
        options.residuals,
    );
    if options.simplify.is_none() {
        analysis.normalise();
    }
    let mut unsimplified = Vec::new();
    if let Some(limits) = options.simplify {
        unsimplified = analysis.simplify(limits).skipped;
    }
    let mut compiled = build(&model, Some(&analysis), text, file_name, diagnostics);
    if options.realise == Realise::Lowest {
        realise(&mut compiled);
    }
    Ok(Output {
        compiled,
        unsimplified,
    })
}

/// The text without its byte-order mark, if it has one: editors on Windows write one, and it
/// is not part of what the user wrote. Diagnostics' spans refer to the text without it.
pub fn without_bom(source: &str) -> &str {
    source.strip_prefix('\u{FEFF}').unwrap_or(source)
}

/// The error for a `der()` whose differentiation passes bgc's bound.
fn oversized(model: &crate::graph::BondGraph, o: Oversized) -> Diagnostic {
    let (span, whose) = match o.holder {
        Holder::Let(l) => {
            let decl = &model.lets[l.index()];
            (decl.span, format!("`{}`", decl.name))
        }
        Holder::Element(n) => {
            let node = model.node(n);
            (node.span, format!("`{}`'s law", node.name))
        }
    };
    Diagnostic::error(
        Code::TooLarge,
        span,
        format!(
            "the `der(…, {})` in {whose} passes bgc's bound of {MOST_DERIVATIVE_NODES} expression nodes at order {}: it is not differentiated further",
            o.asked, o.reached
        ),
    )
    .with_label("this derivative grows too large")
    .with_help(
        "each order of a product of functions is more than twice as large as the one before; \
         measure the derivative, or write a lower order with a `let` for the signal",
    )
}
