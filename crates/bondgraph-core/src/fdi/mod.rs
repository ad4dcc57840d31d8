//! Fault detection and isolation: the ARRs of a model and its fault signature matrix.

mod arr;
pub mod auxiliary;
mod basis;
pub mod eliminate;
mod fsm;
mod operator;
mod sensitivity;

pub use arr::{diagnose, Diagnosis};
pub use fsm::{ComponentKind, Fsm};
