//! The pipeline driver: runs the stages a request needs, in order, on a valid model; how
//! their expressions are shown is `display.rs`, how the product is built `product/`.

use crate::causality::{assign, Causal, Mode};
use crate::fdi::{diagnose, Diagnosis, Fsm};
use crate::graph::BondGraph;
use crate::sim::{state_space_of, StateSpace};

/// What the stages derived from a model; the product is built from it.
pub(crate) struct Analysis<'m> {
    /// The model.
    pub model: &'m BondGraph,
    /// Integral causality (simulation).
    pub integral: Causal,
    /// State equations.
    pub state: StateSpace,
    /// Diagnosis causality, ARRs and the FSM, when they were asked for.
    pub diagnosis: Option<(Diagnosis, Fsm)>,
}

/// Runs the pipeline on a valid model: the state equations always, the ARRs and FSM when
/// `diagnose` says so.
pub(crate) fn analyse(model: &BondGraph, with_arrs: bool) -> Analysis<'_> {
    let integral = assign(model, Mode::Integral);
    let state = state_space_of(model, &integral);
    let diagnosis = with_arrs.then(|| {
        let d = diagnose(model);
        let fsm = Fsm::new(model, &d);
        (d, fsm)
    });
    Analysis {
        model,
        integral,
        state,
        diagnosis,
    }
}
