//! bondgraph-core: the bond-graph compiler as a library.
//!
//! One front door: [`compile`] reads a model's text and gives the [`Compiled`] product (the
//! parameters, inputs, sensors, states, state equations, ARRs, FSM, causality reports and
//! diagnostics), or the diagnostics of a model that is not valid. Expressions of the product
//! are written with a [`Printer`] and evaluated with an [`Evaluator`].

mod causality;
mod compile;
pub mod diagnostic;
mod display;
mod expr;
mod fdi;
#[doc(hidden)]
pub mod generate;
mod graph;
mod index;
mod pipeline;
mod product;
pub mod program;
mod state_space;
mod symbolic;
mod syntax;
mod values;

pub use compile::{compile, without_bom, Derive, Options, Output, Realise};
pub use display::Unsimplified;
pub use expr::{BinOp, Func};
pub use fdi::candidates::{MAX_CANDIDATE_SIZE, MAX_DERIVATIONS, WINDOW_DETECTORS};
pub use fdi::placement::{Goal, NamedClasses, NewDetector, Placement, PlacementError, Proposal};
pub use fdi::ResidualSet;
pub use graph::closest;
pub use product::*;
pub use symbolic::hash::FastMap;
pub use symbolic::rewrite::{Limits, Stop};
pub use symbolic::{children, Derivatives, Evaluator, ExprId, LeafKind, Node, Pool, Printer, Tape};
pub use syntax::ast::{AstExpr, Ident};
pub use syntax::parse_expr;
pub use values::{ParameterValues, ValuesError};

use diagnostic::Diagnostics;

/// Where to add detectors so that `targets` (component names; all when empty) reach `goal`:
/// the second front door, for `bgc sensors`. `Err` holds the diagnostics of a model that is
/// not valid.
pub fn place_sensors(
    source: &str,
    targets: &[String],
    goal: Goal,
) -> Result<Result<Placement, PlacementError>, Diagnostics> {
    let (model, diagnostics) = graph::load(without_bom(source));
    match model {
        Some(model) if !diagnostics.has_errors() => {
            Ok(fdi::placement::place(&model, targets, goal))
        }
        _ => Err(diagnostics),
    }
}

/// The candidate residuals of a model, ready to be chosen from (for benchmarks).
#[doc(hidden)]
pub struct CandidateSet {
    list: Vec<fdi::candidates::Candidate>,
    components: usize,
}

impl CandidateSet {
    /// How many candidates there are.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// How many residuals `--residuals best` keeps, and how many classes they tell apart.
    pub fn best(&self) -> (usize, usize) {
        let kept = fdi::candidates::select(&self.list, self.components, ResidualSet::Best);
        let picked: Vec<_> = kept.iter().map(|&k| &self.list[k]).collect();
        let classes = fdi::candidates::classes_of(&picked, self.components);
        (kept.len(), classes.classes.len())
    }
}

/// The candidate residuals of a model's text (for benchmarks): parsing, the whole model's
/// ARRs and FSM, the structural classes, and one derivation per class (of the part around
/// it, above [`MAX_DERIVATIONS`] classes).
#[doc(hidden)]
pub fn candidate_residuals(source: &str) -> Option<CandidateSet> {
    let (model, diagnostics) = graph::load(source);
    let model = model.filter(|_| !diagnostics.has_errors())?;
    let (list, components) = pipeline::candidate_list(&model);
    Some(CandidateSet { list, components })
}

/// The number of structural fault classes of a model's text (for benchmarks): parsing, the
/// diagnosis equations and the classes, no ARR derived.
#[doc(hidden)]
pub fn structural_classes(source: &str) -> Option<usize> {
    let (model, diagnostics) = graph::load(source);
    let model = model.filter(|_| !diagnostics.has_errors())?;
    let system = causality::equations::build(&model, causality::Mode::Diagnosis);
    let components = fdi::components(&model);
    Some(
        fdi::isolability::structural(&system, &components)
            .classes
            .len(),
    )
}
