//! Every model of `models/` compiled by `bond_graph!` (so the generated code compiles, with
//! warnings denied), and its `residuals` against the product's ARR expressions evaluated by
//! the core's evaluator at random points: the code computes what bgc derived.
#![deny(warnings)]

use std::collections::HashMap;

use bondgraph_core::{compile, Compiled, Evaluator, Expr, Node, Options, ResidualSet, Symbol};

bondgraph::bond_graph!("../../models/backlash_bench.bg");
bondgraph::bond_graph!("../../models/backlash_bench_table3.bg");
bondgraph::bond_graph!("../../models/coulomb_friction.bg");
bondgraph::bond_graph!("../../models/dc_motor.bg");
bondgraph::bond_graph!("../../models/four_mass_chain.bg");
bondgraph::bond_graph!("../../models/hardening_spring.bg");
bondgraph::bond_graph!("../../models/hydraulic_cylinder.bg");
bondgraph::bond_graph!("../../models/loudspeaker.bg");
bondgraph::bond_graph!("../../models/parallel_rlc.bg");
bondgraph::bond_graph!("../../models/quarter_car.bg");
bondgraph::bond_graph!("../../models/resistive_loop.bg");
bondgraph::bond_graph!("../../models/rigid_gear_drive.bg");
bondgraph::bond_graph!("../../models/rlc_series.bg");
bondgraph::bond_graph!("../../models/thermal_two_zone.bg");
bondgraph::bond_graph!("../../models/three_tank.bg");
bondgraph::bond_graph!("../../models/torque_sensor_drive.bg");
bondgraph::bond_graph!("../../models/two_tank.bg");
bondgraph::bond_graph!("../../models/varistor_loop.bg");
bondgraph::bond_graph!("../../models/gas_accumulator.bg");
bondgraph::bond_graph!("../../models/heat_exchanger.bg");
bondgraph::bond_graph!("../../models/heated_tank.bg");
bondgraph::bond_graph!("../../models/orifice_tank.bg");
bondgraph::bond_graph!("../../models/wheatstone_bridge.bg");

/// The residuals `best` keeps: the bench's, two of them simulated (one per encoder), and the
/// two tanks', whose residual without the first level reads the valve's law the other way
/// (no simulated one).
mod best {
    pub(crate) mod bench {
        bondgraph::bond_graph!("../../models/backlash_bench.bg", residuals = best);
    }
    pub(crate) mod tanks {
        bondgraph::bond_graph!("../../models/two_tank.bg", residuals = best);
    }
}
use best::bench::backlash_bench as best_bench;
use best::tanks::two_tank as best_tanks;

/// A value in [-1.5, -0.5] ∪ [0.5, 1.5] from a hash of a name and a point: the same name has
/// the same value at a point, whichever side reads it.
fn random(point: u64, name: &str) -> f64 {
    let mut x = point.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for b in name.bytes() {
        x = (x ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3);
        x ^= x >> 29;
    }
    x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    x ^= x >> 33;
    let u = (x >> 11) as f64 / (1u64 << 53) as f64;
    if u < 0.5 {
        -0.5 - u
    } else {
        u
    }
}

fn product(model: &str, residuals: ResidualSet) -> Compiled {
    let path = format!("{}/../../models/{model}.bg", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("model");
    let options = Options {
        residuals,
        ..Options::default()
    };
    compile(&text, model, &options)
        .unwrap_or_else(|d| panic!("{model}: {d:?}"))
        .compiled
}

/// The name `Signals` gives a symbol.
fn field(c: &Compiled, s: Symbol) -> Option<String> {
    let named = |name: &str, n: u32| match n {
        0 => name.to_string(),
        n => format!("{name}_d{n}"),
    };
    match s {
        Symbol::Input(u, n) => Some(named(&c.inputs[u].name, n)),
        Symbol::Sensor(h, n) => Some(named(&c.sensors[h].name, n)),
        // A simulated residual reads the copy's states.
        Symbol::State(k) => Some(format!("{}_hat", c.states[k].name)),
        Symbol::Root(k, 0) => Some(c.roots[k].name.clone()),
        _ => None,
    }
}

/// Every ARR of `c` as its generator evaluates it (the relation, or the running value of one
/// realised by integration) by the core at the signal values `values`, parameters at the
/// model's values; an integral of a signal reads `NAME_int`, an integral of a linear
/// combination the same combination of those, and the k-th other integral `int{k}`.
fn expected(c: &Compiled, values: &HashMap<String, f64>) -> Vec<f64> {
    let plain = |s: Symbol, suffix: &str| match s {
        Symbol::Parameter(p) => c.parameters[p].value,
        other => field(c, other)
            .and_then(|f| values.get(&format!("{f}{suffix}")).copied())
            .unwrap_or(f64::NAN),
    };
    // A root's derivative is an expression of the roots and the signals.
    let leaf = |s: Symbol, suffix: &str| match s {
        Symbol::Root(k, n) if n > 0 => c.roots[k]
            .derivatives
            .get(n as usize)
            .map_or(f64::NAN, |&d| {
                Evaluator::new(&c.exprs, |s| plain(s, "")).value(d)
            }),
        other => plain(other, suffix),
    };
    let mut integrals = HashMap::new();
    let roots: Vec<Expr> = c.arrs.iter().map(|a| a.evaluated()).collect();
    let nonlinear = c.readings().nonlinear;
    c.exprs.visit_reachable(&roots, |id, node| {
        if let Node::Int(arg) = node {
            let value = match nonlinear.iter().position(|&e| e == arg) {
                Some(k) => values
                    .get(&format!("int{}", k + 1))
                    .copied()
                    .unwrap_or(f64::NAN),
                None => Evaluator::new(&c.exprs, |s| leaf(s, "_int")).value(arg),
            };
            integrals.insert(id, value);
        }
    });
    let mut ev = Evaluator::new(&c.exprs, |s| leaf(s, "")).with_integrals(integrals);
    roots.iter().map(|&r| ev.value(r)).collect()
}

macro_rules! check {
    ($m:ident) => {
        check!($m, stringify!($m), ResidualSet::PerSensor)
    };
    ($m:ident, $model:expr, $set:expr) => {{
        let c = product($model, $set);
        assert!(
            c.auxiliaries.is_empty(),
            "no model of models/ needs an auxiliary signal"
        );
        let p = $m::Params::default();
        let mut finite = vec![0usize; $m::RESIDUALS.len()];
        for point in 0..20u64 {
            let values: Vec<f64> = $m::Signals::NAMES
                .iter()
                .map(|n| random(point, n))
                .collect();
            let by_name: HashMap<String, f64> = $m::Signals::NAMES
                .iter()
                .map(|n| n.to_string())
                .zip(values.iter().copied())
                .collect();
            let array = values.try_into().expect("one value per field");
            let s = $m::Signals::from_array(array);
            assert_eq!(s.to_array(), array);
            let got = $m::residuals(&p, &s);
            let want = expected(&c, &by_name);
            assert_eq!(got.len(), want.len());
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                // Outside a law's domain (the square root of a negative pressure) both
                // evaluations leave the numbers.
                if !w.is_finite() {
                    assert!(
                        !g.is_finite(),
                        "{}: {} at point {point}: generated {g}, core {w}",
                        stringify!($m),
                        $m::RESIDUALS[k]
                    );
                    continue;
                }
                finite[k] += 1;
                assert!(
                    (g - w).abs() <= 1e-9 * w.abs() + 1e-300,
                    "{}: {} at point {point}: generated {g}, core {w}",
                    stringify!($m),
                    $m::RESIDUALS[k]
                );
            }
        }
        // Most points are within every law's domain: the comparison is not vacuous.
        for (k, n) in finite.iter().enumerate() {
            assert!(
                *n >= 5,
                "{}: {} finite at {n} points of 20",
                stringify!($m),
                $m::RESIDUALS[k]
            );
        }
    }};
}

#[test]
fn generated_residuals_equal_the_products_arrs_for_every_model() {
    check!(backlash_bench);
    check!(backlash_bench_table3);
    check!(coulomb_friction);
    check!(dc_motor);
    check!(four_mass_chain);
    check!(hardening_spring);
    check!(hydraulic_cylinder);
    check!(loudspeaker);
    check!(parallel_rlc);
    check!(quarter_car);
    check!(resistive_loop);
    check!(rigid_gear_drive);
    check!(rlc_series);
    check!(thermal_two_zone);
    check!(three_tank);
    check!(torque_sensor_drive);
    check!(two_tank);
    check!(varistor_loop);
    check!(gas_accumulator);
    check!(heat_exchanger);
    check!(heated_tank);
    check!(orifice_tank);
    check!(wheatstone_bridge);
    check!(best_bench, "backlash_bench", ResidualSet::Best);
    check!(best_tanks, "two_tank", ResidualSet::Best);
    assert!(best_bench::SIMULATED.iter().filter(|&&s| s).count() == 2);
    assert!(!best_tanks::SIMULATED.contains(&true));
}
