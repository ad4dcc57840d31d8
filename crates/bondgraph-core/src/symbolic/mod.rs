//! The symbolic expression IR: a hash-consed DAG, so shared subexpressions stay shared.
//!
//! `pool` holds the nodes and the constructors (which fold constants and drop neutral
//! elements), [`derive`] is d/dt with the chain rule, `eval` evaluates numerically,
//! `normal` puts expressions in a canonical form, [`rewrite`] chooses the cheapest way to
//! write them (egg), and [`print`] writes them as text.

mod derive;
mod eval;
pub mod hash;
mod invert;
mod monomial;
mod normal;
mod pool;
mod print;
mod rational;
pub mod rewrite;

pub use derive::{known_signal_rule, Derivatives};
pub use eval::{Evaluator, Tape};
pub(crate) use invert::linear_root_of;
pub use invert::{invert, Condition};
pub use normal::{Polynomial, Simplifier};
pub use pool::{children, ExprId, Leaf, LeafKind, Node, Pool};
pub use print::Printer;
