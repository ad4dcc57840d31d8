//! The symbolic expression IR: a hash-consed DAG, so shared subexpressions stay shared.
//!
//! `pool` holds the nodes and the constructors (which fold constants and drop neutral
//! elements), [`derive`] is d/dt with the chain rule, `eval` evaluates numerically,
//! `normal` puts expressions in a canonical form, [`rewrite`] chooses the cheapest way to
//! write them (egg), and [`print`] writes them as text.

mod derive;
mod eval;
pub(crate) mod hash;
pub(crate) mod invert;
mod monomial;
mod normal;
mod pool;
mod print;
mod rational;
pub(crate) mod rewrite;

pub(crate) use derive::known_signal_rule;
pub use derive::Derivatives;
pub use eval::{Evaluator, Tape};
pub(crate) use invert::linear_root_of;
pub(crate) use invert::{invert, Condition};
pub(crate) use normal::{Polynomial, Simplifier};
pub use pool::{children, ExprId, LeafKind, Node, Pool};
pub(crate) use pool::{AuxIx, Leaf, RootIx, StateIx, VarId};
pub use print::Printer;
