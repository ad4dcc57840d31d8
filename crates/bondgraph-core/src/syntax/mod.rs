//! The `.bg` language: grammar (`bg.pest`), statement splitting, syntax tree.
//!
//! The language is documented for users in `docs/language.md`.

pub mod ast;
mod parser;
mod recover;
mod split;

pub use parser::{parse, parse_expr};
