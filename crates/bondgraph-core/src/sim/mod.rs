//! Simulation: the model in integral causality as state equations, and their integration
//! under a scenario (inputs, closed loops, faults, noise) into sampled signals.

#[cfg(feature = "simulate")]
mod noise;
#[cfg(feature = "simulate")]
mod plant;
#[cfg(feature = "simulate")]
mod run;
mod scenario;
mod state_space;

#[cfg(feature = "simulate")]
pub use run::{SimulationError, Trajectory};
pub use scenario::{parse_scenario, Scenario, Solver, MAX_SAMPLES};
pub(crate) use state_space::{state_space_of, StateSpace};

#[cfg(feature = "simulate")]
use crate::diagnostic::Diagnostics;
#[cfg(feature = "simulate")]
use crate::product::Compiled;

/// A model under a scenario, ready to run.
#[cfg(feature = "simulate")]
#[derive(Clone, Debug)]
pub struct Simulation {
    plant: plant::Plant,
    scenario: Scenario,
}

#[cfg(feature = "simulate")]
impl Simulation {
    /// The plant of `c` driven as `scenario` says, or the scenario's mistakes (their spans are
    /// in the scenario's text).
    pub fn new(c: &Compiled, scenario: &Scenario) -> Result<Simulation, Diagnostics> {
        Ok(Simulation {
            plant: plant::build(c, scenario)?,
            scenario: scenario.clone(),
        })
    }

    /// Integrates over the scenario's duration; `progress` hears the fraction done as it goes.
    pub fn run(&self, progress: impl FnMut(f64)) -> Result<Trajectory, SimulationError> {
        run::run(&self.plant, &self.scenario, progress)
    }
}

#[cfg(all(test, feature = "simulate"))]
mod tests {
    use super::*;
    use crate::{compile, Options};

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
