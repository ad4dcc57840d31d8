//! Everything bgc derives from a model, in one place for the emitters.

use crate::causality::{assign, Causal, Mode, StorageCausality, Strong};
use crate::fdi::{diagnose, Diagnosis, Fsm};
use crate::graph::{BondGraph, NodeId, NodeKind};
use crate::sim::{state_space, StateSpace};

/// The causality of one mode, as a report names it.
pub struct CausalityReport {
    /// The mode.
    pub mode: Mode,
    /// Each storage element and the causality it took.
    pub storage: Vec<(NodeId, StorageCausality)>,
    /// Each junction and what sets its common variable.
    pub strong: Vec<(NodeId, Option<Strong>)>,
    /// Problems: conflicts, loops, refused causality.
    pub problems: Vec<String>,
}

/// A model and what bgc derived from it.
pub struct Analysis<'m> {
    /// The model.
    pub model: &'m BondGraph,
    /// Integral causality (simulation).
    pub integral: Causal,
    /// State equations.
    pub state: StateSpace,
    /// Diagnosis causality and ARRs.
    pub diagnosis: Diagnosis,
    /// The fault signature matrix.
    pub fsm: Fsm,
}

/// Runs the whole pipeline on a valid model.
pub fn analyse(model: &BondGraph) -> Analysis<'_> {
    let integral = assign(model, Mode::Integral);
    let state = state_space(model);
    let diagnosis = diagnose(model);
    let fsm = Fsm::new(model, &diagnosis);
    Analysis {
        model,
        integral,
        state,
        diagnosis,
        fsm,
    }
}

impl Analysis<'_> {
    /// The causality report of a mode.
    pub fn causality(&self, mode: Mode) -> CausalityReport {
        let (causal, problems) = match mode {
            Mode::Integral => (&self.integral, self.state.problems.clone()),
            Mode::Diagnosis => (&self.diagnosis.causal, self.diagnosis.problems.clone()),
        };
        let mut problems = problems;
        for refusal in &causal.system.refusals {
            let text = format!(
                "`{}`: {}",
                self.model.node(refusal.element).name,
                refusal.reason
            );
            if !problems.contains(&text) {
                problems.push(text);
            }
        }
        let strong = self
            .model
            .nodes()
            .filter(|&n| matches!(self.model.node(n).kind, NodeKind::Junction(_)))
            .map(|n| (n, causal.strong_bond(self.model, n)))
            .collect();
        CausalityReport {
            mode,
            storage: causal.storage(self.model),
            strong,
            problems,
        }
    }
}
