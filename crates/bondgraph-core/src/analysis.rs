//! Everything bgc derives from a model, in one place for the emitters.

use crate::causality::{assign, Causal, Mode, StorageCausality, Strong};
use crate::fdi::{diagnose, Diagnosis, Fsm};
use crate::graph::{BondGraph, NodeId};
use crate::sim::{state_space_of, StateSpace};
use crate::symbolic::rewrite::{Limits, Rewriter, Stop};

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
    let state = state_space_of(model, &integral);
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

/// An expression shown in its canonical form because the search for a simpler one was cut
/// short by the clock or never started.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsimplified {
    /// What the expression is: `ARR2`, `der(p_Lm)`, the output `y1`.
    pub what: String,
    /// Why: [`Stop::TimeLimit`], [`Stop::TooLarge`] or [`Stop::Budget`].
    pub stop: Stop,
}

impl Analysis<'_> {
    /// Rewrites every expression the emitters show (ARRs first, then state equations and
    /// detector outputs) into the cheapest form egg finds within `limits`. The FSM and the
    /// derivations are already done on the canonical forms; only how each is written changes.
    pub fn simplify(&mut self, limits: Limits) -> Vec<Unsimplified> {
        let rewriter = Rewriter::new(limits);
        let mut spent = 0usize;
        let mut skipped = Vec::new();
        let mut choose = |pool: &mut _, root, what: &dyn Fn() -> String| {
            if spent >= limits.budget {
                skipped.push(Unsimplified {
                    what: what(),
                    stop: Stop::Budget,
                });
                return root;
            }
            let r = rewriter.cheapest(pool, root);
            spent = spent.saturating_add(r.nodes);
            if matches!(r.stop, Stop::TimeLimit | Stop::TooLarge) {
                skipped.push(Unsimplified {
                    what: what(),
                    stop: r.stop,
                });
            }
            r.expr
        };
        let pool = &mut self.diagnosis.causal.system.pool;
        for arr in &mut self.diagnosis.arrs {
            arr.residual = choose(pool, arr.residual, &|| arr.name.clone());
        }
        let state = &mut self.state;
        for s in &mut state.states {
            s.rhs = choose(&mut state.pool, s.rhs, &|| format!("der({})", s.name));
        }
        for (sensor, e) in &mut state.outputs {
            let name = &self.model.node(*sensor).name;
            *e = choose(&mut state.pool, *e, &|| format!("the output {name}"));
        }
        skipped
    }

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
            .filter(|&n| self.model.node(n).is_junction())
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

/// Small graphs whose equations a person can derive by hand, in both causalities.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::{Leaf, Pool, Printer};

    struct Derived {
        states: Vec<String>,
        outputs: Vec<String>,
        arrs: Vec<String>,
        integral: Vec<(String, StorageCausality)>,
        derivative: Vec<(String, StorageCausality)>,
    }

    fn derive(text: &str) -> Derived {
        let (model, diagnostics) = crate::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:#?}"));
        let a = analyse(&model);
        assert!(a.state.problems.is_empty(), "{:?}", a.state.problems);
        assert!(
            a.diagnosis.problems.is_empty(),
            "{:?}",
            a.diagnosis.problems
        );
        let names = |pool: &Pool, e| {
            Printer::new(pool, |l| match l {
                Leaf::Param(p) => model.params[p.0 as usize].name.clone(),
                Leaf::Input(u, 0) => model.inputs[u.0 as usize].name.clone(),
                Leaf::Input(u, n) => format!("der({}, {n})", model.inputs[u.0 as usize].name),
                Leaf::Sensor(s, 0) => model.node(s).name.clone(),
                Leaf::Sensor(s, n) => format!("der({}, {n})", model.node(s).name),
                Leaf::State(k) => a.state.states[k as usize].name.clone(),
                other => format!("{other:?}"),
            })
            .text(e)
        };
        let storage = |r: CausalityReport| -> Vec<(String, StorageCausality)> {
            r.storage
                .into_iter()
                .map(|(n, c)| (model.node(n).name.clone(), c))
                .collect()
        };
        Derived {
            states: a
                .state
                .states
                .iter()
                .map(|s| format!("{}' = {}", s.name, names(&a.state.pool, s.rhs)))
                .collect(),
            outputs: a
                .state
                .outputs
                .iter()
                .map(|(s, e)| format!("{} = {}", model.node(*s).name, names(&a.state.pool, *e)))
                .collect(),
            arrs: a
                .diagnosis
                .arrs
                .iter()
                .map(|arr| {
                    format!(
                        "{}@{}: {}",
                        arr.name,
                        model.node(arr.junction).name,
                        names(&a.diagnosis.causal.system.pool, arr.residual)
                    )
                })
                .collect(),
            integral: storage(a.causality(Mode::Integral)),
            derivative: storage(a.causality(Mode::Diagnosis)),
        }
    }

    const HEAD: &str =
        "model t\nparam R1 = 2\nparam C1 = 3\nparam L1 = 5\nparam m = 7\nparam r = 11\ninput U\n";

    #[test]
    fn rc_circuit() {
        // Se U -> 1 -> R, C.  Integral: q' = f = e_R / R1 = (U - q/C1) / R1.
        // Diagnosis with the current i, C in derivative causality: e_C = U - R1 i from the
        // junction, so i = C1 d/dt(U - R1 i): i - C1 U' + R1 C1 i' = 0 (no integral needed).
        let d = derive(&format!(
            "{HEAD}Se u = U\nR res = R1\nC cap = C1\nDf i on j\nu -> 1:j -> res, cap\n"
        ));
        assert_eq!(d.states, ["q_cap' = U / R1 - q_cap / (R1 * C1)"]);
        assert_eq!(d.outputs, ["i = U / R1 - q_cap / (R1 * C1)"]);
        assert_eq!(d.arrs, ["ARR1@j: R1 * C1 * der(i, 1) - C1 * der(U, 1) + i"]);
        assert_eq!(d.integral, [("cap".into(), StorageCausality::Integral)]);
        assert_eq!(d.derivative, [("cap".into(), StorageCausality::Derivative)]);
    }

    #[test]
    fn rc_with_a_voltage_sensor_takes_derivative_causality() {
        // Parallel RC fed by a current source; v measured on the 0-junction:
        // Sf I -> 0 -> R, C.  ARR: I - v/R1 - C1 v' = 0.  State: q' = I - q/(C1 R1).
        let d = derive(&format!(
            "{HEAD}Sf src = U\nR res = R1\nC cap = C1\nDe v on n\nsrc -> 0:n -> res, cap\n"
        ));
        assert_eq!(d.states, ["q_cap' = U - q_cap / (R1 * C1)"]);
        assert_eq!(d.arrs, ["ARR1@n: U - v / R1 - C1 * der(v, 1)"]);
        assert_eq!(d.derivative, [("cap".into(), StorageCausality::Derivative)]);
    }

    #[test]
    fn rl_circuit() {
        // Se U -> 1 -> R, I.  p' = U - R1 p / L1.  With i measured: U - R1 i - L1 i' = 0.
        let d = derive(&format!(
            "{HEAD}Se u = U\nR res = R1\nI ind = L1\nDf i on j\nu -> 1:j -> res, ind\n"
        ));
        assert_eq!(d.states, ["p_ind' = U - R1 * p_ind / L1"]);
        assert_eq!(d.outputs, ["i = p_ind / L1"]);
        assert_eq!(d.arrs, ["ARR1@j: U - R1 * i - L1 * der(i, 1)"]);
        assert_eq!(d.derivative, [("ind".into(), StorageCausality::Derivative)]);
    }

    #[test]
    fn transformer() {
        // Se U -> 1:a -> TF(m) -> 1:b -> I, R.  e1 = m e2, f2 = m f1.
        // The load sees e2 = U/m and its velocity is f2; p' = U/m - r p/L1.
        // With v = f2 measured: U/m - r v - L1 v' = 0.
        let d = derive(&format!(
            "{HEAD}Se u = U\nTF tf = m\nI load = L1\nR fr = r\nDf v on b\nu -> 1:a -> tf -> 1:b -> load, fr\n"
        ));
        assert_eq!(d.states, ["p_load' = U / m - p_load * r / L1"]);
        assert_eq!(d.arrs, ["ARR1@b: U / m - L1 * der(v, 1) - r * v"]);
    }

    #[test]
    fn gyrator() {
        // A DC motor: Se U -> 1:e -> R, I(L), GY(r) -> 1:s -> I(m).  e1 = r f2, e2 = r f1.
        // p_L' = U - R1 p_L/L1 - r p_m/m;  p_m' = r p_L / L1.
        // Detectors i (current) and w (speed): U - R1 i - L1 i' - r w = 0 and r i - m w' = 0.
        let d = derive(&format!(
            "{HEAD}Se u = U\nR res = R1\nI ind = L1\nGY gy = r\nI rotor = m\nDf i on e\nDf w on s\n\
             u -> 1:e -> res, ind, gy\ngy -> 1:s -> rotor\n"
        ));
        assert_eq!(
            d.states,
            [
                "p_ind' = U - R1 * p_ind / L1 - r * p_rotor / m",
                "p_rotor' = p_ind * r / L1"
            ]
        );
        assert_eq!(
            d.arrs,
            [
                "ARR1@e: U - R1 * i - L1 * der(i, 1) - r * w",
                "ARR2@s: r * i - m * der(w, 1)"
            ]
        );
    }

    #[test]
    fn a_linear_algebraic_loop_is_torn_and_solved() {
        // U through R1 to node b; from b, R2 to ground and R3 in series with C. No storage
        // sets the node, so the three resistors form an algebraic loop. By hand, with
        // v the node voltage: (U - v)/R1 = v/R2 + (v - q/C1)/R3, and q' = (v - q/C1)/R3.
        let text = format!(
            "{HEAD}param R2 = 13\nparam R3 = 17\nSe u = U\nR r1 = R1\nR r2 = R2\nR r3 = R3\nC cap = C1\n\
             u -> 1:a -> r1\na -> 0:b -> r2\nb -> 1:c -> r3, cap\n"
        );
        let (model, _) = crate::load(&text);
        let model = model.expect("valid");
        let a = analyse(&model);
        assert!(a.state.problems.is_empty(), "{:?}", a.state.problems);
        let (u, q) = (3.0, 0.7);
        let (r1, r2, r3, c1) = (2.0, 13.0, 17.0, 3.0);
        let v = (u / r1 + q / (c1 * r3)) / (1.0 / r1 + 1.0 / r2 + 1.0 / r3);
        let expected = (v - q / c1) / r3;
        let values: Vec<f64> = model.params.iter().map(|p| p.value).collect();
        let got = crate::symbolic::Evaluator::new(&a.state.pool, |l| match l {
            Leaf::Param(p) => values[p.0 as usize],
            Leaf::Input(..) => u,
            Leaf::State(_) => q,
            _ => f64::NAN,
        })
        .value(a.state.states[0].rhs);
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    }

    #[test]
    fn a_nonlinear_algebraic_loop_is_reported() {
        let text = format!(
            "{HEAD}Se u = U\nR r1 : f = e^3\nR r2 = R1\nR r3 = C1\nC cap = C1\n\
             u -> 1:a -> r1\na -> 0:b -> r2\nb -> 1:c -> r3, cap\n"
        );
        let (model, _) = crate::load(&text);
        let model = model.expect("valid");
        let a = analyse(&model);
        assert!(
            a.state
                .problems
                .iter()
                .any(|p| p.contains("algebraic loop")),
            "{:?}",
            a.state.problems
        );
    }

    #[test]
    fn two_port_chain() {
        // Two masses joined by a spring, driven by a force F on the first:
        // Se F -> 1:v1 -> I(m); v1 -> 0:k -> C(stiffness 1/C1 ... written as C = C1); k -> 1:v2 -> I(L1).
        // Spring force e = q/C1, q' = v1 - v2; m v1' = F - e, L1 v2' = e.  With v1, v2 measured
        // the spring force comes from the first mass, e = F - m v1', so:
        // at the spring, v1 - v2 = C1 e' = C1 (F' - m v1''); at the second mass, F - m v1' = L1 v2'.
        let d = derive(&format!(
            "{HEAD}Se f = U\nI m1 = m\nC k = C1\nI m2 = L1\nDf v1 on a\nDf v2 on b\n\
             f -> 1:a -> m1\na -> 0:n -> k\nn -> 1:b -> m2\n"
        ));
        assert_eq!(
            d.states,
            [
                "p_m1' = U - q_k / C1",
                "q_k' = p_m1 / m - p_m2 / L1",
                "p_m2' = q_k / C1"
            ]
        );
        assert_eq!(
            d.arrs,
            [
                "ARR1@n: m * C1 * der(v1, 2) - C1 * der(U, 1) + v1 - v2",
                "ARR2@b: U - m * der(v1, 1) - L1 * der(v2, 1)"
            ]
        );
    }
}
