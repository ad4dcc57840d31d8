//! The symbolic expression IR: a hash-consed DAG, so shared subexpressions stay shared.
//!
//! [`pool`] holds the nodes and the constructors (which fold constants and drop neutral
//! elements), [`derive`] is d/dt with the chain rule, [`eval`] evaluates numerically and
//! [`print`] writes expressions as text.

mod derive;
mod eval;
mod normal;
mod pool;
mod print;

pub use derive::{known_signal_rule, Derivatives};
pub use eval::Evaluator;
pub use normal::{Simplifier, MAX_TERMS};
pub use pool::{ExprId, Leaf, Node, Pool};
pub use print::Printer;
