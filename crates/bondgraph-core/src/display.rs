//! How expressions are shown: the display policy applied to what the pipeline derived, once
//! the derivations and the FSM are done on canonical forms. Only how each expression is
//! written changes here, never what it is.

use crate::pipeline::Analysis;
use crate::symbolic::rewrite::length;
use crate::symbolic::rewrite::{Limits, Rewriter, Stop};
use crate::symbolic::{ExprId, Pool, Simplifier};

/// An expression shown in its canonical form because the search for a simpler one was
/// skipped, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsimplified {
    /// What the expression is: `ARR2`, `der(p_Lm)`, the output `y1`.
    pub what: String,
    /// Why: [`Stop::TooLarge`] or [`Stop::Budget`].
    pub stop: Stop,
}

/// How simplification went: what was left canonical.
pub(crate) struct Simplified {
    /// Expressions left in canonical form by a count limit.
    pub skipped: Vec<Unsimplified>,
}

impl Analysis<'_> {
    /// For `--canonical`: every shown expression with the terms that share reciprocals of
    /// sums over their common denominator (see [`Simplifier::together`]), where that is
    /// shorter to read.
    pub(crate) fn normalise(&mut self) {
        let shorter = |pool: &mut Pool, simplifier: &mut Simplifier, e: ExprId| {
            let mut best = e;
            let together = simplifier.together(pool, e);
            let rational = simplifier.rational(pool, e).unwrap_or(e);
            for candidate in [together, rational] {
                if candidate != best && length(pool, candidate) < length(pool, best) {
                    best = candidate;
                }
            }
            best
        };
        if let Some(diagnosed) = &mut self.diagnosis {
            let keep: Vec<(usize, usize)> = diagnosed
                .chosen
                .iter()
                .filter_map(|c| c.derived())
                .collect();
            for (source, d) in diagnosed.sources.iter_mut().enumerate() {
                let mut simplifier = Simplifier::default();
                for (k, arr) in d.arrs.iter_mut().enumerate() {
                    if keep.contains(&(source, k)) {
                        arr.residual =
                            shorter(&mut d.causal.system.pool, &mut simplifier, arr.residual);
                    }
                }
            }
        }
        let mut simplifier = Simplifier::default();
        let state = &mut self.state;
        for s in &mut state.states {
            s.rhs = shorter(&mut state.pool, &mut simplifier, s.rhs);
        }
        for (_, e) in &mut state.outputs {
            *e = shorter(&mut state.pool, &mut simplifier, *e);
        }
    }

    /// Rewrites every expression the emitters show (ARRs first, then state equations and
    /// detector outputs) into the cheapest form egg finds within `limits`. The FSM and the
    /// derivations are already done on the canonical forms; only how each is written changes.
    /// Only counts decide the forms, never the clock.
    pub(crate) fn simplify(&mut self, limits: Limits) -> Simplified {
        let rewriter = Rewriter::new(limits);
        let mut spent = 0usize;
        let mut skipped = Vec::new();
        let mut simplifier = Simplifier::default();
        let mut state_simplifier = Simplifier::default();
        let mut choose = |pool: &mut Pool,
                          simplifier: &mut Simplifier,
                          root: ExprId,
                          what: &dyn Fn() -> String| {
            if spent >= limits.budget {
                skipped.push(Unsimplified {
                    what: what(),
                    stop: Stop::Budget,
                });
                return root;
            }
            let mut r = rewriter.cheapest(pool, root);
            spent = spent.saturating_add(r.nodes);
            // The forms over a common denominator are other starting points: the terms over
            // a sum put together, and the whole in lowest terms (nested fractions opened,
            // common factors cancelled). Each is kept when its best form is strictly shorter.
            let together = simplifier.together(pool, root);
            let rational = simplifier.rational(pool, root).unwrap_or(root);
            for start in [together, rational] {
                if start == root {
                    continue;
                }
                let t = rewriter.cheapest(pool, start);
                spent = spent.saturating_add(t.nodes);
                if t.after < r.after {
                    r = t;
                }
            }
            if r.stop == Stop::TooLarge {
                skipped.push(Unsimplified {
                    what: what(),
                    stop: r.stop,
                });
            }
            r.expr
        };
        if let Some(diagnosed) = &mut self.diagnosis {
            let keep: Vec<(usize, usize)> = diagnosed
                .chosen
                .iter()
                .filter_map(|c| c.derived())
                .collect();
            // Named as the product will name them: by their place among those kept.
            let name = |source: usize, k: usize| {
                let at = keep.iter().position(|&x| x == (source, k)).unwrap_or(0);
                format!("ARR{}", at + 1)
            };
            for (source, d) in diagnosed.sources.iter_mut().enumerate() {
                let pool = &mut d.causal.system.pool;
                // A simplifier remembers expressions of one pool.
                let mut fresh = Simplifier::default();
                let simplifier = if source == 0 {
                    &mut simplifier
                } else {
                    &mut fresh
                };
                for (k, arr) in d.arrs.iter_mut().enumerate() {
                    if keep.contains(&(source, k)) {
                        arr.residual = choose(pool, simplifier, arr.residual, &|| name(source, k));
                    }
                }
            }
        }
        let state = &mut self.state;
        for s in &mut state.states {
            s.rhs = choose(&mut state.pool, &mut state_simplifier, s.rhs, &|| {
                format!("der({})", s.name)
            });
        }
        for (sensor, e) in &mut state.outputs {
            let name = &self.model.node(*sensor).name;
            *e = choose(&mut state.pool, &mut state_simplifier, *e, &|| {
                format!("the output {name}")
            });
        }
        Simplified { skipped }
    }
}
