//! Writes a CSV of the bench's simulated samples for the `bench_csv` example: the armature
//! voltage and both speeds every 5 ms for 8 s, with the armature resistance 50 % higher from
//! 4 s on (a fault appearing mid-record).
//!
//! `cargo run -p bondgraph --example simulate_bench > bench.csv`

use bondgraph_core::{compile, Evaluator, Expr, Node, Options, Symbol};

const STEP: f64 = 5e-3;
const SECONDS: f64 = 8.0;
const FAULT_AT: f64 = 4.0;

fn voltage(t: f64) -> f64 {
    2.0 * (0.8 * t).sin() + 0.5 * (2.3 * t).sin()
}

fn main() {
    let text = include_str!("../../../models/backlash_bench.bg");
    let c = match compile(text, "backlash_bench.bg", &Options::default()) {
        Ok(out) => out.compiled,
        Err(d) => {
            eprintln!("the bench does not compile: {d:?}");
            std::process::exit(1);
        }
    };
    let Some(space) = c.state_space.as_ref() else {
        eprintln!("the bench has no state equations");
        std::process::exit(1);
    };
    let rhs: Vec<Expr> = space.equations.iter().map(|(_, e)| *e).collect();
    let mut integrals: Vec<Expr> = Vec::new();
    c.exprs.visit_reachable(&rhs, |id, node| {
        if matches!(node, Node::Int(_)) {
            integrals.push(id);
        }
    });
    let mut rates = rhs.clone();
    rates.extend(integrals.iter().map(|&id| match c.exprs.node(id) {
        Node::Int(arg) => arg,
        _ => id,
    }));
    let outputs: Vec<Expr> = space.outputs.iter().map(|(_, e)| *e).collect();
    let n = rhs.len();
    let eval = |x: &[f64], t: f64, roots: &[Expr]| -> Vec<f64> {
        let leaf = |s: Symbol| match s {
            Symbol::Parameter(p) => {
                let q = &c.parameters[p];
                let fault = if q.name == "Re" && t >= FAULT_AT {
                    1.5
                } else {
                    1.0
                };
                q.value * fault
            }
            Symbol::State(k) => x[k.index()],
            Symbol::Input(..) => voltage(t),
            Symbol::Time => t,
            _ => f64::NAN,
        };
        let ints = integrals
            .iter()
            .enumerate()
            .map(|(i, &id)| (id, x[n + i]))
            .collect();
        let mut ev = Evaluator::new(&c.exprs, leaf).with_integrals(ints);
        roots.iter().map(|&r| ev.value(r)).collect()
    };
    // Integrated finer than sampled, so that the record is exact to far below the residuals.
    let sub = 10;
    let h = STEP / f64::from(sub);
    let mut x = vec![0.0; rates.len()];
    println!("t,U0,y1,y2");
    for k in 0..=(SECONDS / STEP) as usize {
        let t = k as f64 * STEP;
        let y = eval(&x, t, &outputs);
        println!("{t:.3},{:.12e},{:.12e},{:.12e}", voltage(t), y[0], y[1]);
        for j in 0..sub {
            let s = t + f64::from(j) * h;
            let add = |x: &[f64], d: &[f64], a: f64| -> Vec<f64> {
                x.iter().zip(d).map(|(u, v)| u + a * v).collect()
            };
            let k1 = eval(&x, s, &rates);
            let k2 = eval(&add(&x, &k1, h / 2.0), s + h / 2.0, &rates);
            let k3 = eval(&add(&x, &k2, h / 2.0), s + h / 2.0, &rates);
            let k4 = eval(&add(&x, &k3, h), s + h, &rates);
            for i in 0..x.len() {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
    }
}
