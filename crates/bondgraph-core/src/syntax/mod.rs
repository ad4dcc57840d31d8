//! The `.bg` language: grammar (`bg.pest`), statement splitting, syntax tree.
//!
//! The language is documented for users in `docs/language.md`.

pub(crate) mod ast;
mod parser;
mod recover;
mod split;

pub(crate) use parser::parse;
pub use parser::parse_expr;
