//! The bond graph: its model types, lowering from the syntax tree, and structural checks.

mod bonds;
mod faults;
mod laws;
mod lets;
mod lower;
pub(crate) mod model;
mod scope;
mod validate;

pub(crate) use lets::{first_too_large, MAX_EXPANDED};
pub(crate) use lower::load;
pub use model::Carried;
pub(crate) use model::*;
pub use scope::closest;

#[cfg(test)]
mod tests;
