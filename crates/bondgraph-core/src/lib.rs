//! bondgraph-core: the bond-graph compiler as a library.
//!
//! [`load`] reads a model's text into a validated [`graph::BondGraph`]: the `.bg` syntax
//! ([`syntax`]), then lowering and checks ([`graph`]), with [`diagnostic`]s tied to source spans.

pub mod analysis;
pub mod causality;
pub mod diagnostic;
pub mod expr;
pub mod fdi;
pub mod generate;
pub mod graph;
pub mod sim;
pub mod symbolic;
pub mod syntax;

use diagnostic::Diagnostics;
use graph::BondGraph;

/// Parses, lowers and validates a model; the graph is `None` when any error was found.
/// Diagnostics (warnings too) come sorted by position.
pub fn load(text: &str) -> (Option<BondGraph>, Diagnostics) {
    let (file, mut diagnostics) = syntax::parse(text);
    let graph = graph::lower(&file, &mut diagnostics);
    diagnostics.sort();
    let graph = graph.filter(|_| !diagnostics.has_errors());
    (graph, diagnostics)
}
