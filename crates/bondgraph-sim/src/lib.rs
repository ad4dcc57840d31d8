//! bondgraph-sim: what reads the compiler's product to run it.
//!
//! A [`Scenario`] (inputs, closed loops, faults, noise) drives a [`Simulation`] of a
//! [`Compiled`](bondgraph_core::Compiled) model into a [`Trajectory`]; [`verify`] checks the
//! derived ARRs and FSM along such trajectories. The compiler (`bondgraph-core`) does not
//! depend on this crate, so that what derives equations does not carry the ODE solver.

mod newton;
mod noise;
mod plant;
mod run;
mod scenario;
mod simulation;
mod verify;

pub use noise::{gaussian, uniform};
pub use run::{SimulationError, Trajectory};
pub use scenario::{parse_scenario, Scenario, Solver, MAX_SAMPLES};
pub use simulation::Simulation;
pub use verify::{
    verify, verify_reporting, ArrCheck, EntryCheck, Progress, Verification, VerifyError,
    VerifyOptions, ZeroCrossings,
};
