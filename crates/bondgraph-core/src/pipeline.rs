//! The pipeline driver: runs the stages a request needs, in order, on a valid model.

use crate::causality::{assign, Causal, Mode};
use crate::fdi::{diagnose, Diagnosis, Fsm};
use crate::graph::BondGraph;
use crate::sim::{state_space_of, StateSpace};
use crate::symbolic::rewrite::{Limits, Rewriter, Stop};

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

/// An expression shown in its canonical form because the search for a simpler one was
/// skipped, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsimplified {
    /// What the expression is: `ARR2`, `der(p_Lm)`, the output `y1`.
    pub what: String,
    /// Why: [`Stop::TooLarge`] or [`Stop::Budget`].
    pub stop: Stop,
}

/// How simplification went: what was left canonical, and whether the clock aborted it.
pub(crate) struct Simplified {
    /// Expressions left in canonical form by a count limit.
    pub skipped: Vec<Unsimplified>,
    /// The first expression whose search the wall clock stopped, if any.
    pub timed_out: Option<String>,
}

impl Analysis<'_> {
    /// Rewrites every expression the emitters show (ARRs first, then state equations and
    /// detector outputs) into the cheapest form egg finds within `limits`. The FSM and the
    /// derivations are already done on the canonical forms; only how each is written changes.
    /// Only counts decide the forms; the clock can only abort the whole run.
    pub fn simplify(&mut self, limits: Limits) -> Simplified {
        let rewriter = Rewriter::new(limits);
        let mut spent = 0usize;
        let mut skipped = Vec::new();
        let mut timed_out = None;
        let mut choose = |pool: &mut _, root, what: &dyn Fn() -> String| {
            if timed_out.is_some() {
                return root;
            }
            if spent >= limits.budget {
                skipped.push(Unsimplified {
                    what: what(),
                    stop: Stop::Budget,
                });
                return root;
            }
            let r = rewriter.cheapest(pool, root);
            spent = spent.saturating_add(r.nodes);
            match r.stop {
                Stop::TimeLimit => timed_out = Some(what()),
                Stop::TooLarge => skipped.push(Unsimplified {
                    what: what(),
                    stop: r.stop,
                }),
                _ => {}
            }
            r.expr
        };
        if let Some((d, _)) = &mut self.diagnosis {
            let pool = &mut d.causal.system.pool;
            for arr in &mut d.arrs {
                arr.residual = choose(pool, arr.residual, &|| arr.name.clone());
            }
        }
        let state = &mut self.state;
        for s in &mut state.states {
            s.rhs = choose(&mut state.pool, s.rhs, &|| format!("der({})", s.name));
        }
        for (sensor, e) in &mut state.outputs {
            let name = &self.model.node(*sensor).name;
            *e = choose(&mut state.pool, *e, &|| format!("the output {name}"));
        }
        Simplified { skipped, timed_out }
    }
}
