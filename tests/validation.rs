//! Numeric validation of the derived equations on every model in `models/`.
//!
//! The plant is simulated from its own state equations (RK4) from several initial states with
//! non-trivial inputs. The detector signals and every time derivative an ARR needs are computed
//! exactly, by differentiating the outputs along the state equations (no finite differences),
//! and the integrals an ARR needs are integrated with the plant. Then:
//! - every residual stays at round-off level on the nominal plant;
//! - with one parameter changed in the plant only, the residuals the FSM marks for it move
//!   away from zero and the others stay at round-off level.
//!
//! What is checked is what bgc shows: the state equations and ARRs as the e-graph rewrote
//! them (`Analysis::simplify`), so a wrong rewrite fails here as surely as a wrong derivation.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use bondgraph_core::analysis::{analyse, Analysis};
use bondgraph_core::expr::BinOp;
use bondgraph_core::generate::mass_spring_chain_varied;
use bondgraph_core::graph::NodeId;
use bondgraph_core::symbolic::{Derivatives, Evaluator, ExprId, Leaf, Node, Pool, Simplifier};

/// Inputs: u_k(t) = scale · (1 + 0.5 sin(ω_k t + k)), with exact derivatives of any order.
fn input(k: u32, n: u32, t: f64, scale: f64) -> f64 {
    let w = 1.3 + 0.7 * f64::from(k);
    let phase = w * t + f64::from(k);
    let d = w.powi(n as i32) * 0.5 * (phase + f64::from(n) * std::f64::consts::FRAC_PI_2).sin();
    scale * if n == 0 { 1.0 + d } else { d }
}

/// Per-model scales: (input amplitude, typical state magnitude).
fn scales(name: &str) -> (f64, f64) {
    match name {
        "two_tank" | "three_tank" => (1e-4, 0.02),
        "quarter_car" => (0.2, 0.05),
        _ => (1.0, 0.5),
    }
}

/// The plant: its state equations, the residuals rewritten over its states, and the
/// integrals both need, all in one pool.
struct Plant {
    pool: Pool,
    rhs: Vec<ExprId>,
    /// `int(..)` nodes, integrated along with the states.
    integrals: Vec<ExprId>,
    /// The residuals; `Leaf::Var(p)` stands for parameter `p` at its nominal value.
    residuals: Vec<ExprId>,
    /// The terms of each residual's top-level sum: round-off is relative to their size.
    terms: Vec<Vec<ExprId>>,
}

/// The terms of `e` read as a sum (signs dropped: only their size matters). A canonical
/// sum is a chain as long as its terms, so this walks it with a stack of its own.
fn terms(pool: &Pool, e: ExprId, out: &mut Vec<ExprId>) {
    let mut stack = vec![e];
    while let Some(e) = stack.pop() {
        match pool.node(e) {
            Node::Binary(BinOp::Add | BinOp::Sub, a, b) => stack.extend([a, b]),
            Node::Neg(a) => stack.push(a),
            _ => out.push(e),
        }
    }
}

fn plant(analysis: &Analysis<'_>, canonical: bool) -> (Plant, Vec<ExprId>) {
    let (model, ss, diagnosis) = (analysis.model, &analysis.state, &analysis.diagnosis);
    assert!(ss.problems.is_empty(), "{}: {:?}", model.name, ss.problems);
    assert!(
        diagnosis.problems.is_empty(),
        "{}: {:?}",
        model.name,
        diagnosis.problems
    );
    let mut pool = ss.pool.clone();
    let rhs: Vec<ExprId> = ss.states.iter().map(|s| s.rhs).collect();
    let outputs: HashMap<NodeId, ExprId> = ss.outputs.iter().copied().collect();
    // n-th derivative of each output along the state equations, memoised.
    let mut derived: HashMap<(NodeId, u32), ExprId> = HashMap::new();
    let mut residuals = Vec::new();
    for arr in &diagnosis.arrs {
        let r = pool.import(
            &diagnosis.causal.system.pool,
            arr.residual,
            &mut |p, leaf| match leaf {
                Leaf::Sensor(s, n) => {
                    output_derivative(p, &rhs, &outputs, &mut derived, (s, n), canonical)
                }
                Leaf::Param(id) => p.leaf(Leaf::Var(id.0)),
                other => p.leaf(other),
            },
        );
        residuals.push(r);
    }
    let mut roots = rhs.clone();
    roots.extend(&residuals);
    let mut integrals = Vec::new();
    pool.visit_reachable(&roots, |id, node| {
        if let Node::Int(_) = node {
            integrals.push(id);
        }
    });
    let arr_exprs = residuals.clone();
    let terms = residuals
        .iter()
        .map(|&r| {
            let mut out = Vec::new();
            terms(&pool, r, &mut out);
            out
        })
        .collect();
    (
        Plant {
            pool,
            rhs,
            integrals,
            residuals,
            terms,
        },
        arr_exprs,
    )
}

fn output_derivative(
    pool: &mut Pool,
    rhs: &[ExprId],
    outputs: &HashMap<NodeId, ExprId>,
    derived: &mut HashMap<(NodeId, u32), ExprId>,
    (sensor, n): (NodeId, u32),
    canonical: bool,
) -> ExprId {
    if let Some(&e) = derived.get(&(sensor, n)) {
        return e;
    }
    let e = if n == 0 {
        outputs[&sensor]
    } else {
        let lower = output_derivative(pool, rhs, outputs, derived, (sensor, n - 1), canonical);
        let mut d = Derivatives::new(|p: &mut Pool, leaf: Leaf| match leaf {
            Leaf::State(k) => Some(rhs[k as usize]),
            Leaf::Input(u, m) => Some(p.leaf(Leaf::Input(u, m + 1))),
            Leaf::Param(_) | Leaf::Var(_) => Some(p.num(0.0)),
            Leaf::Time => Some(p.num(1.0)),
            Leaf::Sensor(..) | Leaf::Tear(..) => None,
        });
        let e = d
            .of(pool, lower)
            .expect("outputs are functions of states and inputs");
        // For a linear plant the canonical form is a short sum over the states, and keeps
        // the next derivative from growing by the product rule; for a nonlinear one it is
        // larger than the DAG it comes from.
        if canonical {
            Simplifier::default().simplify(pool, e)
        } else {
            e
        }
    };
    derived.insert((sensor, n), e);
    e
}

/// A point of the augmented state: states, then integrals.
struct Run<'a> {
    plant: &'a Plant,
    plant_params: Vec<f64>,
    nominal: Vec<f64>,
    input_scale: f64,
}

impl Run<'_> {
    fn leaf(&self, x: &[f64], t: f64) -> impl Fn(Leaf) -> f64 + '_ {
        let x = x.to_vec();
        move |leaf| match leaf {
            Leaf::State(k) => x[k as usize],
            Leaf::Param(p) => self.plant_params[p.0 as usize],
            Leaf::Var(p) => self.nominal[p as usize],
            Leaf::Input(u, n) => input(u.0, n, t, self.input_scale),
            Leaf::Time => t,
            Leaf::Sensor(..) | Leaf::Tear(..) => f64::NAN,
        }
    }

    fn integrals(&self, x: &[f64]) -> HashMap<ExprId, f64> {
        let n = self.plant.rhs.len();
        self.plant
            .integrals
            .iter()
            .enumerate()
            .map(|(i, &id)| (id, x[n + i]))
            .collect()
    }

    fn derivative(&self, x: &[f64], t: f64) -> Vec<f64> {
        let mut ev =
            Evaluator::new(&self.plant.pool, self.leaf(x, t)).with_integrals(self.integrals(x));
        let mut out: Vec<f64> = self.plant.rhs.iter().map(|&e| ev.value(e)).collect();
        for &id in &self.plant.integrals {
            let Node::Int(arg) = self.plant.pool.node(id) else {
                unreachable!()
            };
            out.push(ev.value(arg));
        }
        out
    }

    /// Each residual, over the size of its largest term when that exceeds 1: a residual
    /// with terms of 1e6 vanishes to round-off at 1e-10, not at 1e-16.
    fn residuals(&self, x: &[f64], t: f64) -> Vec<f64> {
        let mut ev =
            Evaluator::new(&self.plant.pool, self.leaf(x, t)).with_integrals(self.integrals(x));
        self.plant
            .residuals
            .iter()
            .zip(&self.plant.terms)
            .map(|(&r, terms)| {
                let size = terms.iter().map(|&e| ev.value(e).abs()).fold(1.0, f64::max);
                ev.value(r) / size
            })
            .collect()
    }

    /// Largest relative |residual| of each ARR along an RK4 trajectory from `x0`.
    fn worst(&self, x0: &[f64], steps: usize, h: f64) -> Vec<f64> {
        let mut x: Vec<f64> = x0.to_vec();
        x.extend(std::iter::repeat_n(0.0, self.plant.integrals.len()));
        let mut worst = vec![0.0f64; self.plant.residuals.len()];
        for step in 0..steps {
            let t = step as f64 * h;
            for (w, r) in worst.iter_mut().zip(self.residuals(&x, t)) {
                assert!(r.is_finite(), "residual not finite at t = {t}");
                *w = w.max(r.abs());
            }
            let add = |x: &[f64], k: &[f64], s: f64| -> Vec<f64> {
                x.iter().zip(k).map(|(a, b)| a + s * b).collect()
            };
            let k1 = self.derivative(&x, t);
            let k2 = self.derivative(&add(&x, &k1, h / 2.0), t + h / 2.0);
            let k3 = self.derivative(&add(&x, &k2, h / 2.0), t + h / 2.0);
            let k4 = self.derivative(&add(&x, &k3, h), t + h);
            for i in 0..x.len() {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        worst
    }
}

fn models() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("models/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "bg"))
        .collect();
    paths.sort();
    paths
}

#[test]
fn residuals_vanish_on_the_model_and_move_with_the_parameters_the_fsm_names() {
    for path in models() {
        let text = std::fs::read_to_string(&path).expect("model");
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        validate(&text, scales(name), false);
    }
}

/// Chains whose ARRs are freed of torn unknowns by elimination over d/dt (the force between
/// two measured masses is never measured): each ARR must hold exactly, and a fault in one
/// stage must move exactly the ARRs of the detectors around it.
///
/// The residual is checked at every state the trajectory visits, with exact derivatives, so
/// a short, coarse trajectory is as strict as a fine one; it keeps this test quick.
#[test]
fn local_arrs_of_chains_vanish_and_each_stage_moves_the_arrs_around_it() {
    validate(&mass_spring_chain_varied(7, 3), (1.0, 0.5), true);
}

/// Simulates `text`'s model healthy and with each parameter +20%, checking every residual.
/// `linear` says the plant is linear: its output derivatives are kept in canonical form, and a
/// coarser trajectory is enough (the chains' ARRs are large to evaluate).
fn validate(text: &str, (input_scale, state_scale): (f64, f64), linear: bool) {
    {
        let (model, diagnostics) = bondgraph_core::load(text);
        let model = model.unwrap_or_else(|| panic!("{diagnostics:?}"));
        let mut analysis = analyse(&model);
        let unsimplified = analysis.simplify(Default::default());
        assert!(unsimplified.is_empty(), "{unsimplified:?}");
        let (plant, _) = plant(&analysis, linear);
        assert_eq!(
            plant.residuals.len(),
            model.counts().detectors,
            "{}: one ARR per detector",
            model.name
        );
        let fsm = &analysis.fsm;
        let nominal: Vec<f64> = model.params.iter().map(|p| p.value).collect();
        let n = plant.rhs.len();
        let initial: Vec<Vec<f64>> = (0..3)
            .map(|seed| {
                (0..n)
                    .map(|i| state_scale * (0.4 + 0.37 * ((i * 7 + seed * 3) % 5) as f64))
                    .collect()
            })
            .collect();
        let (steps, h) = if linear { (150, 1e-2) } else { (1500, 1e-3) };
        for x0 in &initial {
            let run = Run {
                plant: &plant,
                plant_params: nominal.clone(),
                nominal: nominal.clone(),
                input_scale,
            };
            let healthy = run.worst(x0, steps, h);
            for (i, w) in healthy.iter().enumerate() {
                assert!(
                    *w < 1e-8,
                    "{}: ARR{} = {w:e} on the healthy plant",
                    model.name,
                    i + 1
                );
            }
        }
        for (p, param) in model.params.iter().enumerate() {
            let expected: BTreeSet<usize> = fsm
                .rows
                .iter()
                .filter(|r| r.component.parameters.iter().any(|q| q.0 as usize == p))
                .flat_map(|r| r.marks.iter().copied())
                .collect();
            let mut faulty = nominal.clone();
            faulty[p] *= 1.2;
            let run = Run {
                plant: &plant,
                plant_params: faulty,
                nominal: nominal.clone(),
                input_scale,
            };
            let worst = run.worst(&initial[0], steps, h);
            for (i, w) in worst.iter().enumerate() {
                if expected.contains(&i) {
                    assert!(
                        *w > 1e-6,
                        "{}: {} +20% should move ARR{} but it stays at {w:e}",
                        model.name,
                        param.name,
                        i + 1
                    );
                } else {
                    assert!(
                        *w < 1e-8,
                        "{}: {} +20% should not move ARR{} but it reaches {w:e}",
                        model.name,
                        param.name,
                        i + 1
                    );
                }
            }
        }
    }
}
