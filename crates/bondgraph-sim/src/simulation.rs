//! Simulation: the model's state equations integrated under a scenario (inputs, closed
//! loops, faults, noise) into sampled signals.

use bondgraph_core::diagnostic::{Diagnostics, Span};
use bondgraph_core::Compiled;

use crate::plant;
use crate::run::{self, SimulationError, Trajectory};
use crate::scenario::Scenario;

/// A model under a scenario, ready to run.
#[derive(Clone, Debug)]
pub struct Simulation {
    plant: plant::Plant,
    scenario: Scenario,
}

impl Simulation {
    /// The plant of `c` driven as `scenario` says, or the scenario's mistakes (their spans are
    /// in the scenario's text).
    pub fn new(c: &Compiled, scenario: &Scenario) -> Result<Simulation, Diagnostics> {
        Ok(Simulation {
            plant: plant::build(c, scenario)?,
            scenario: scenario.clone(),
        })
    }

    /// Where in the scenario's text the cause of `e` is written, if it is there: the line
    /// that defines an input or `let` that is not a finite number.
    pub fn locate(&self, e: &SimulationError) -> Option<Span> {
        let SimulationError::NotFinite { signal, .. } = e else {
            return None;
        };
        let defined = self.scenario.inputs.iter().chain(&self.scenario.lets);
        defined
            .map(|(name, _)| name)
            .find(|name| name.name == *signal)
            .map(|name| name.span)
    }

    /// Integrates over the scenario's duration; `progress` hears the fraction done as it goes.
    pub fn run(&self, progress: impl FnMut(f64)) -> Result<Trajectory, SimulationError> {
        run::run(&self.plant, &self.scenario, progress)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::parse_scenario;
    use bondgraph_core::{compile, Options};

    pub(super) const RC: &str = "model rc\nparam R1 = 2 [Ohm]\nparam C1 = 0.5 [F]\ninput I [A]\n\
                      Sf src = I\nC cap = C1\nR res = R1\nDe v on n\nsrc -> 0:n -> cap, res\n";

    fn simulate(model: &str, scenario: &str) -> Result<Trajectory, String> {
        let c = compile(model, "m.bg", &Options::default())
            .map_err(|d| format!("{d:?}"))?
            .compiled;
        let (s, d) = parse_scenario(scenario);
        let s = s.ok_or_else(|| format!("{d:?}"))?;
        let sim = Simulation::new(&c, &s).map_err(|d| format!("{d:?}"))?;
        sim.run(|_| {}).map_err(|e| e.to_string())
    }

    fn column<'a>(t: &'a Trajectory, name: &str) -> &'a [f64] {
        let k = t.columns.iter().position(|c| c == name).expect("column");
        &t.values[k]
    }

    /// Largest |simulated - exact| over the samples of `name`.
    fn worst(t: &Trajectory, name: &str, exact: impl Fn(f64) -> f64) -> f64 {
        column(t, "t")
            .iter()
            .zip(column(t, name))
            .map(|(&t, &v)| (v - exact(t)).abs())
            .fold(0.0, f64::max)
    }

    /// A resolution rounds each sample to its nearest multiple; an encoder's samples are
    /// whole counts per sample, which add up to the signal's integral to within a count.
    #[test]
    fn quantisers_round_to_a_resolution_and_count_an_encoders_turns() {
        let base = "duration 2\nstep 0.01\ninput I = 3\n";
        let exact = simulate(RC, base).expect("runs");
        let v = column(&exact, "v");
        let rounded = simulate(RC, &format!("{base}resolution v 0.25\n")).expect("runs");
        for (r, v) in column(&rounded, "v").iter().zip(v) {
            assert!(
                (r - v).abs() <= 0.125 + 1e-12 && (r / 0.25).fract() == 0.0,
                "{r} {v}"
            );
        }
        let counted = simulate(RC, &format!("{base}encoder v 100\n")).expect("runs");
        let (quantum, h) = (std::f64::consts::TAU / 100.0, 0.01);
        let mut integral = 0.0;
        let mut counts = 0.0;
        for (k, c) in column(&counted, "v").iter().enumerate() {
            let n = c * h / quantum;
            assert!((n - n.round()).abs() < 1e-9, "{c}");
            if k > 0 {
                integral += 0.5 * (v[k] + v[k - 1]) * h;
            }
            counts += c * h;
            assert!((counts - integral).abs() <= quantum + 1e-12, "{k}");
        }
        assert!(integral > 10.0 * quantum);
    }

    /// An RC discharge, v = v0 exp(-t / RC), to 1e-7 of v0 with both solvers.
    #[test]
    fn an_rc_discharge_follows_its_exponential() {
        for solver in ["dopri5", "implicit"] {
            let t = simulate(
                RC,
                &format!(
                    "duration 5\nstep 0.01\nsolver {solver}\ninput I = 0\ninitial q_cap = 2\n"
                ),
            )
            .expect("runs");
            assert_eq!(column(&t, "t").len(), 501);
            let err = worst(&t, "v", |t| 4.0 * (-t).exp());
            assert!(err < 4e-7, "{solver}: {err}");
            assert!(err > 0.0);
        }
    }

    /// The series RLC with no source is a damped oscillator: q = e^(-at)(q0 cos wt + a q0/w sin wt).
    #[test]
    fn a_damped_oscillator_follows_its_closed_form() {
        let model = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/rlc_series.bg"
        ))
        .expect("model");
        let t = simulate(
            &model,
            "duration 0.2\nstep 1e-4\ninput V = 0\ninitial q_cap = 1e-3\n",
        )
        .expect("runs");
        let (a, w) = (50.0f64, (10_000.0f64 - 2500.0).sqrt());
        let q = |t: f64| (-a * t).exp() * 1e-3 * ((w * t).cos() + a / w * (w * t).sin());
        let err = worst(&t, "q_cap", q);
        assert!(err < 1e-10, "{err}");
    }

    /// A damped mass–spring, released from a stretch: x = e^(-at)(x0 cos wt + a x0/w sin wt)
    /// with a = b/2m and w = √(k/m − a²), to 1e-9 of x0 with both solvers.
    #[test]
    fn a_damped_mass_spring_follows_its_closed_form() {
        let model = "model msd\nparam m = 2 [kg]\nparam b = 0.8 [N.s/m]\nparam c = 0.125 [m/N]\n\
                     input F [N]\nSe f = F\nI mass = m\nR damp = b\nC spring = c\nDf v on j\n\
                     f -> 1:j -> mass, damp, spring\n";
        let (a, x0) = (0.2f64, 0.1f64);
        let w = (8.0f64 / 2.0 - a * a).sqrt();
        let x = |t: f64| (-a * t).exp() * x0 * ((w * t).cos() + a / w * (w * t).sin());
        for solver in ["dopri5", "implicit"] {
            let t = simulate(
                model,
                &format!(
                    "duration 10\nstep 0.01\nsolver {solver}\ntolerance 1e-10\ninput F = 0\n\
                     initial q_spring = {x0}\n"
                ),
            )
            .expect("runs");
            let err = worst(&t, "q_spring", x);
            assert!(err < 1e-9 * x0, "{solver}: {err}");
            // The speed is the stretch's rate: v = x'.
            let v = |t: f64| -x0 * (-a * t).exp() * (a * a / w + w) * (w * t).sin();
            let err = worst(&t, "v", v);
            assert!(err < 1e-8 * x0, "{solver}: {err}");
        }
    }

    /// `int(..)` in an input is a state of its own: a current equal to t (the integral of 1)
    /// charges the RC as q = RC t - (RC)^2 (1 - exp(-t/RC)).
    #[test]
    fn an_integral_in_an_input_is_integrated_with_the_plant() {
        let t = simulate(RC, "duration 3\nstep 0.01\ninput I = int(1)\n").expect("runs");
        let err = worst(&t, "q_cap", |t| t - (1.0 - (-t).exp()));
        assert!(err < 1e-7, "{err}");
        let err = worst(&t, "I", |t| t);
        assert!(err < 1e-9, "{err}");
    }

    /// A loop closed on a measured signal: I = -k v makes the decay rate 1/RC + k/C.
    #[test]
    fn a_loop_closed_on_a_measured_signal_changes_the_dynamics() {
        let t = simulate(
            RC,
            "duration 2\nstep 0.01\nlet k = 0.25\ninput I = -k*v\ninitial q_cap = 1\n",
        )
        .expect("runs");
        let err = worst(&t, "q_cap", |t| (-1.5 * t).exp());
        assert!(err < 1e-7, "{err}");
    }

    /// An input that reads its own effect at the same instant is refused, at the input.
    #[test]
    fn an_algebraic_loop_through_an_input_is_refused() {
        let scenario = "input I = 1 + der(v)\n";
        let err = simulate(RC, scenario).expect_err("refused");
        assert!(err.contains("AlgebraicLoop"), "{err}");
    }

    /// Faults: a parameter step, a sensor offset and an actuator gain, each from its time on.
    #[test]
    fn faults_act_from_their_time() {
        let t = simulate(
            RC,
            "duration 2\nstep 0.5\ninput I = 1\nfault sensor v + 0.5 at 1\nfault actuator I * 0 at 1.5\n",
        )
        .expect("runs");
        let v = column(&t, "v");
        let q = column(&t, "q_cap");
        // Before 1 s the sensor reads q / C; after, 0.5 more.
        assert!((v[1] - q[1] / 0.5).abs() < 1e-12);
        assert!((v[2] - q[2] / 0.5 - 0.5).abs() < 1e-12);
        // The record keeps the commanded current; the plant gets none after 1.5 s.
        assert_eq!(column(&t, "I"), &[1.0; 5]);
        let q_15 = q[3];
        assert!((q[4] - q_15 * (-0.5f64).exp()).abs() < 1e-7, "{q:?}");
        let drift = simulate(
            RC,
            "duration 1\nstep 0.5\ninput I = 0\ninitial q_cap = 1\nfault C1 = 2*C1 from 0 to 1\n",
        );
        assert!(drift.is_ok());
    }

    /// A modulated source reading `int(..)` of a measured signal (as the bench's twist does)
    /// makes the integral a state: `m v' = U − K ∫v` from rest is the oscillator
    /// `v = U / √(K m) · sin(√(K/m) t)`.
    #[test]
    fn an_integral_in_a_law_is_an_augmented_state() {
        let model = "model osc\nparam m = 2\nparam K = 8\ninput U\nSe u = U\nI mass = m\n\
                     MSe spring = -K*int(v)\nDf v on a\nu -> 1:a -> mass\nspring -> a\n";
        let t = simulate(model, "duration 3\nstep 0.01\ninput U = 1\n").expect("runs");
        let (w, amplitude) = ((8.0f64 / 2.0).sqrt(), 1.0 / (16.0f64).sqrt());
        let err = worst(&t, "v", |t| amplitude * (w * t).sin());
        assert!(err < 1e-7, "{err}");
        let err = worst(&t, "p_mass", |t| 2.0 * amplitude * (w * t).sin());
        assert!(err < 2e-7, "{err}");
    }

    /// The loop of `NL`: `r1`'s cubic law, `r2` and the branch through `r3` and `cap` set each
    /// other. With e the effort across `r1`, the junction `b` at U − e, and the branch flow
    /// f = e³ − (U − e)/R1: `q' = f`, and e solves (U − e) − R3 f − q/C = 0.
    const NL: &str = "model nl\nparam R1 = 2\nparam R3 = 3\nparam C1 = 0.5\ninput U\nSe u = U\n\
                      R r1 : f = e^3\nR r2 = R1\nR r3 = R3\nC cap = C1\nDf y on c\n\
                      u -> 1:a -> r1\na -> 0:b -> r2\nb -> 1:c -> r3, cap\n";

    /// The same plant integrated independently: the loop by bisection, the state by RK4.
    fn nl_reference(duration: f64, u: impl Fn(f64) -> f64) -> Vec<(f64, f64, f64)> {
        let (r1, r3, c) = (2.0, 3.0, 0.5);
        let flow = |e: f64, u: f64| e.powi(3) - (u - e) / r1;
        // The residual falls as e rises: one root, bracketed.
        let effort = |q: f64, u: f64| {
            let g = |e: f64| (u - e) - r3 * flow(e, u) - q / c;
            let (mut lo, mut hi) = (-100.0, 100.0);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if g(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let rate = |t: f64, q: f64| flow(effort(q, u(t)), u(t));
        let h = 1e-4;
        let mut out = Vec::new();
        let mut q = 0.0;
        for k in 0..=(duration / h).round() as usize {
            let t = k as f64 * h;
            if k % 100 == 0 {
                out.push((t, q, rate(t, q)));
            }
            let k1 = rate(t, q);
            let k2 = rate(t + h / 2.0, q + h / 2.0 * k1);
            let k3 = rate(t + h / 2.0, q + h / 2.0 * k2);
            let k4 = rate(t + h, q + h * k3);
            q += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        out
    }

    /// A nonlinear algebraic loop simulates, its unknown found by Newton's method at every
    /// evaluation, and agrees with the independent integration.
    #[test]
    fn a_nonlinear_algebraic_loop_is_solved_by_newton() {
        let t = simulate(
            NL,
            "duration 4\nstep 0.01\ntolerance 1e-10\ninput U = 1 + 0.5*sin(3*t)\n",
        )
        .expect("runs");
        let reference = nl_reference(4.0, |t| 1.0 + 0.5 * (3.0 * t).sin());
        let (q, y) = (column(&t, "q_cap"), column(&t, "y"));
        assert_eq!(q.len(), reference.len());
        for (k, &(at, q_ref, y_ref)) in reference.iter().enumerate() {
            assert!(
                (q[k] - q_ref).abs() < 1e-8,
                "q at {at}: {} vs {q_ref}",
                q[k]
            );
            assert!(
                (y[k] - y_ref).abs() < 1e-7,
                "y at {at}: {} vs {y_ref}",
                y[k]
            );
        }
        assert!(q[q.len() - 1] > 0.1, "the capacitor charges");
    }

    /// A loop whose laws have no common solution stops the run with the loop's unknown and
    /// the time, not with a number that is not one.
    #[test]
    fn a_loop_without_solution_is_reported() {
        let model = NL.replace("f = e^3", "f = e^2 + 1");
        let err = simulate(&model, "duration 1\nstep 0.1\ninput U = -10\n").expect_err("no root");
        assert!(err.contains("Newton") && err.contains("`e_a_r1`"), "{err}");
        assert!(err.contains("t = 0 s"), "{err}");
    }

    /// Names the model does not have are reported at the name, with what was expected.
    #[test]
    fn unknown_names_are_reported_where_written() {
        let scenario = "input I = 1 + w\nnoise y9 0.1\n";
        let err = simulate(RC, scenario).expect_err("refused");
        assert!(err.contains("`w` is not a name"), "{err}");
        assert!(
            err.contains("`y9` is not an input or measured signal"),
            "{err}"
        );
    }
}
