//! Fault detection and isolation: the ARRs of a model and its fault signature matrix.

mod arr;
pub(crate) mod auxiliary;
mod basis;
pub(crate) mod candidates;
pub(crate) mod component;
mod dominators;
pub(crate) mod eliminate;
mod fsm;
pub(crate) mod isolability;
mod operator;
pub(crate) mod partial;
pub(crate) mod placement;
pub(crate) mod roots;
mod sensitivity;
pub(crate) mod simulated;
pub(crate) mod structure;
mod subsets;

pub(crate) use arr::{diagnose, Diagnosis};
pub use candidates::ResidualSet;
pub(crate) use component::{components, signal_names, Component, ComponentKind};
pub(crate) use fsm::{Fsm, RowIndex};
