//! `verify` on every model in `models/` and on a chain with per-stage parameters: every
//! residual vanishes on the model's own trajectories and moves exactly where the FSM says.
//! What is checked is what bgc prints: the product's rewritten expressions.

use bondgraph_core::generate::mass_spring_chain_varied;
use bondgraph_core::{compile, Compiled, Options, Printer, Symbol};
use bondgraph_sim::{verify, VerifyOptions};

/// Per-model scales: (input amplitude, typical state magnitude).
fn scales(name: &str) -> (f64, f64) {
    match name {
        "two_tank" | "three_tank" => (1e-4, 0.02),
        "quarter_car" => (0.2, 0.05),
        _ => (1.0, 0.5),
    }
}

#[path = "common/models.rs"]
mod listing;
use listing::models;

fn compiled(text: &str, name: &str) -> Compiled {
    let out = compile(text, name, &Options::default()).unwrap_or_else(|d| panic!("{name}: {d:?}"));
    assert!(out.unsimplified.is_empty(), "{:?}", out.unsimplified);
    assert!(
        !out.compiled.has_errors(),
        "{name}: {:?}",
        out.compiled.diagnostics
    );
    out.compiled
}

fn check(c: &Compiled, options: &VerifyOptions) {
    assert_eq!(
        c.arrs.len(),
        c.sensors.len(),
        "{}: one ARR per detector",
        c.name
    );
    let v = verify(c, options).unwrap_or_else(|e| panic!("{}: {e}", c.name));
    for a in &v.arrs {
        assert!(
            a.pass,
            "{}: {} = {:e} on the healthy plant",
            c.name, a.name, a.worst
        );
    }
    for e in &v.entries {
        assert!(
            e.pass,
            "{}: a fault of {} {} {} (it reaches {:e})",
            c.name,
            c.components[e.component].name,
            if e.marked {
                "should move but leaves"
            } else {
                "should not move but moves"
            },
            c.arrs[e.arr].name,
            e.worst
        );
    }
    assert!(v.passed());
}

#[test]
fn residuals_vanish_on_the_model_and_move_with_the_parameters_the_fsm_names() {
    for path in models() {
        let text = std::fs::read_to_string(&path).expect("model");
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        let c = compiled(&text, name);
        let (input_scale, state_scale) = scales(name);
        // A nonlinear algebraic loop (the varistor's) is solved by Newton's method wherever
        // the plant is evaluated, its unknown differentiated implicitly.
        check(
            &c,
            &VerifyOptions {
                input_scale,
                state_scale,
                ..VerifyOptions::default()
            },
        );
    }
}

/// Chains whose ARRs are freed of torn unknowns by elimination over d/dt: each ARR must hold
/// exactly, and a fault in one stage must move exactly the ARRs of the detectors around it.
/// The residual is checked at every state the trajectory visits, with exact derivatives, so a
/// short, coarse trajectory is as strict as a fine one.
#[test]
fn local_arrs_of_chains_vanish_and_each_stage_moves_the_arrs_around_it() {
    let c = compiled(&mass_spring_chain_varied(7, 3), "chain");
    check(
        &c,
        &VerifyOptions {
            steps: 150,
            step: 1e-2,
            ..VerifyOptions::default()
        },
    );
}

/// The text of each ARR as the emitters write it: the relation, then each auxiliary signal
/// it reads with its definition.
fn arr_texts(c: &Compiled) -> Vec<String> {
    let der = |n: &str, k: u32| match k {
        0 => n.to_string(),
        k => format!("der({n}, {k})"),
    };
    let printer = Printer::new(&c.exprs, |s| match s {
        Symbol::Parameter(p) => c.parameters[p].name.clone(),
        Symbol::Input(u, k) => der(&c.inputs[u].name, k),
        Symbol::Sensor(h, k) => der(&c.sensors[h].name, k),
        Symbol::Auxiliary(a, k) => der(&c.auxiliaries[a].name, k),
        Symbol::State(k) => c.states[k].name.clone(),
        Symbol::Time => "t".to_string(),
        // Only state equations hold the loops' unknowns.
        Symbol::Loop(_) => "loop".to_string(),
        Symbol::Root(k, n) => der(&c.roots[k].name, n),
    });
    c.arrs
        .iter()
        .map(|arr| {
            let mut text = printer.text(arr.expr);
            for &a in &arr.auxiliaries {
                let aux = &c.auxiliaries[a];
                text += &format!("\n{} = {}", aux.name, printer.text(aux.definition()));
            }
            for &k in &arr.roots {
                let root = &c.roots[k];
                text += &format!("\n{} solves {} = 0", root.name, printer.text(root.residual));
            }
            text
        })
        .collect()
}

/// Real machines have parameters of their own per stage. Between two detectors of such a
/// chain, each stretch of unmeasured masses has an operator in d/dt of high degree; the ARR
/// of a detector with a stretch on each side applies one to what the other leaves.
/// Multiplied out, that was 8 MB of text at 10 stages; with the part it is applied to named
/// as an auxiliary signal, each ARR stays the same size however long the chain, and holds
/// exactly (checked at 10 stages, where every ARR reads auxiliary signals or neighbours).
#[test]
fn per_stage_chains_have_arrs_under_100_kb_that_verify() {
    for stages in [10, 100, 1000] {
        let c = compiled(&mass_spring_chain_varied(stages, 5), "chain");
        assert_eq!(c.arrs.len(), stages.div_ceil(5), "{stages} stages");
        let texts = arr_texts(&c);
        let largest = texts.iter().map(String::len).max().unwrap_or(0);
        assert!(
            largest < 100_000,
            "{stages} stages: an ARR of {largest} bytes"
        );
        assert!(
            c.arrs.iter().any(|a| !a.auxiliaries.is_empty()),
            "{stages} stages: no auxiliary signal, so no stretch was on both sides"
        );
        if stages == 10 {
            check(
                &c,
                &VerifyOptions {
                    steps: 100,
                    step: 1e-2,
                    ..VerifyOptions::default()
                },
            );
        }
    }
}

/// The check can fail: a residual with a parameter changed in the printed ARR only is caught.
#[test]
fn a_wrong_arr_fails_verification() {
    let text = "model rl\nparam R1 = 2\nparam L1 = 5\ninput U\nSe u = U\nR res = R1\nI ind = L1\n\
                Df i on j\nu -> 1:j -> res, ind\n";
    let mut c = compiled(text, "rl");
    // Replace the ARR by one that is off by a term: U - R1 i - L1 i' + 0.1 R1.
    let arr = c.arrs[0].expr;
    let r1 = c.exprs.leaf(bondgraph_core::Symbol::Parameter(
        c.parameters.find(|p| p.name == "R1").expect("R1"),
    ));
    let tenth = c.exprs.num(0.1);
    let off = c.exprs.mul(tenth, r1);
    c.arrs[0].expr = c.exprs.add(arr, off);
    let v = verify(&c, &VerifyOptions::default()).expect("runs");
    assert!(!v.arrs[0].pass, "{v:?}");
    assert!(!v.passed());
}
