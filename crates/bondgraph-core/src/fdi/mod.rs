//! Fault detection and isolation: the ARRs of a model and its fault signature matrix.

mod arr;
pub mod eliminate;
mod fsm;

pub use arr::{diagnose, Arr, Diagnosis};
pub use fsm::{components, Component, ComponentKind, Fsm, Row};
