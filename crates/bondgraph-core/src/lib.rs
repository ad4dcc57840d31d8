//! bondgraph-core: the bond-graph compiler as a library.
//!
//! So far: the `.bg` syntax ([`syntax`]), the expression tree shared by every stage ([`expr`])
//! and diagnostics tied to source spans ([`diagnostic`]).

pub mod diagnostic;
pub mod expr;
pub mod syntax;
