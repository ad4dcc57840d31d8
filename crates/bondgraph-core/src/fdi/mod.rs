//! Fault detection and isolation: the ARRs of a model and its fault signature matrix.

mod arr;
pub mod auxiliary;
mod basis;
pub mod candidates;
pub mod component;
mod dominators;
pub mod eliminate;
mod fsm;
pub mod isolability;
mod operator;
pub mod placement;
pub mod roots;
mod sensitivity;
pub mod simulated;
pub mod structure;
mod subsets;

pub use arr::{diagnose, Diagnosis};
pub use candidates::ResidualSet;
pub use component::{components, Component, ComponentKind};
pub use fsm::{Fsm, RowIndex};
