//! Small graphs whose equations a person can derive by hand, in both causalities: the
//! conventions of the language (power directions, TF and GY moduli, storage laws) checked
//! through the product, as a user of the library sees them.

use bondgraph_core::diagnostic::Code;
use bondgraph_core::{
    compile, Compiled, Derive, Evaluator, Mode, Options, Printer, StorageCausality, Symbol,
};

struct Derived {
    states: Vec<String>,
    outputs: Vec<String>,
    arrs: Vec<String>,
    integral: Vec<(String, StorageCausality)>,
    derivative: Vec<(String, StorageCausality)>,
}

fn canonical() -> Options {
    Options {
        derive: Derive::Everything,
        simplify: None,
        ..Options::default()
    }
}

fn compiled(text: &str) -> Compiled {
    let out = compile(text, "test.bg", &canonical()).unwrap_or_else(|d| panic!("{d:#?}"));
    // The shared header declares parameters a graph may not use: warnings only.
    assert!(
        !out.compiled.has_errors(),
        "{:#?}",
        out.compiled.diagnostics
    );
    out.compiled
}

fn name(c: &Compiled, s: Symbol) -> String {
    let der = |n: &str, k: u32| match k {
        0 => n.to_string(),
        k => format!("der({n}, {k})"),
    };
    match s {
        Symbol::Parameter(p) => c.parameters[p].name.clone(),
        Symbol::Input(u, k) => der(&c.inputs[u].name, k),
        Symbol::Sensor(s, k) => der(&c.sensors[s].name, k),
        Symbol::State(k) => c.states[k].name.clone(),
        Symbol::Auxiliary(a, k) => der(&c.auxiliaries[a].name, k),
        Symbol::Time => "t".to_string(),
        Symbol::Loop(k) => c
            .state_space
            .as_ref()
            .map_or_else(String::new, |s| s.loops[k.index()].name.clone()),
        Symbol::Root(k, n) => der(&c.roots[k].name, n),
    }
}

fn derive(text: &str) -> Derived {
    let c = compiled(text);
    let printer = Printer::new(&c.exprs, |s| name(&c, s));
    let space = c.state_space.as_ref().expect("state equations");
    let storage = |mode: Mode| -> Vec<(String, StorageCausality)> {
        c.causality
            .iter()
            .find(|r| r.mode == mode)
            .expect("report")
            .storage
            .clone()
    };
    Derived {
        states: space
            .equations
            .iter()
            .map(|(k, e)| format!("{}' = {}", c.states[*k].name, printer.text(*e)))
            .collect(),
        outputs: space
            .outputs
            .iter()
            .map(|(s, e)| format!("{} = {}", c.sensors[*s].name, printer.text(*e)))
            .collect(),
        arrs: c
            .arrs
            .iter()
            .map(|a| format!("{}@{}: {}", a.name, a.junction, printer.text(a.expr)))
            .collect(),
        integral: storage(Mode::Simulation),
        derivative: storage(Mode::Diagnosis),
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
fn a_position_encoder_reads_the_integral_of_the_flow() {
    // Se U -> 1 -> R, I; an encoder's position x = ∫v (`Dq`). Integral causality: p' =
    // U - R1 p/L1 as with a speed sensor, and x one more state, x' = p/L1. Diagnosis: v = x',
    // so U - R1 x' - L1 x'' = 0.
    let d = derive(&format!(
        "{HEAD}Se u = U\nR res = R1\nI ind = L1\nDq x on j\nu -> 1:j -> res, ind\n"
    ));
    assert_eq!(
        d.states,
        ["p_ind' = U - R1 * p_ind / L1", "q_x' = p_ind / L1"]
    );
    assert_eq!(d.outputs, ["x = q_x"]);
    assert_eq!(d.arrs, ["ARR1@j: U - R1 * der(x, 1) - L1 * der(x, 2)"]);
}

#[test]
fn a_momentum_sensor_reads_the_integral_of_the_effort() {
    // Sf U -> 0 -> R, C; the integral of the common effort (`Dp`, a flux linkage λ = ∫v):
    // v = λ', so U - λ'/R1 - C1 λ'' = 0, and λ' = q/C1 is a state of its own.
    let d = derive(&format!(
        "{HEAD}Sf src = U\nR res = R1\nC cap = C1\nDp lam on n\nsrc -> 0:n -> res, cap\n"
    ));
    assert_eq!(
        d.states,
        ["q_cap' = U - q_cap / (R1 * C1)", "p_lam' = q_cap / C1"]
    );
    assert_eq!(d.outputs, ["lam = p_lam"]);
    assert_eq!(d.arrs, ["ARR1@n: U - der(lam, 1) / R1 - C1 * der(lam, 2)"]);
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
    let c = compiled(&text);
    let (u, q) = (3.0, 0.7);
    let (r1, r2, r3, c1) = (2.0, 13.0, 17.0, 3.0);
    let v = (u / r1 + q / (c1 * r3)) / (1.0 / r1 + 1.0 / r2 + 1.0 / r3);
    let expected = (v - q / c1) / r3;
    let space = c.state_space.as_ref().expect("state equations");
    let got = Evaluator::new(&c.exprs, |s| match s {
        Symbol::Parameter(p) => c.parameters[p].value,
        Symbol::Input(..) => u,
        Symbol::State(_) => q,
        _ => f64::NAN,
    })
    .value(space.equations[0].1);
    assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
}

#[test]
fn a_nonlinear_algebraic_loop_is_held_as_an_implicit_unknown() {
    let text = format!(
        "{HEAD}Se u = U\nR r1 : f = e^3\nR r2 = R1\nR r3 = C1\nC cap = C1\n\
         u -> 1:a -> r1\na -> 0:b -> r2\nb -> 1:c -> r3, cap\n"
    );
    let out = compile(&text, "loop.bg", &canonical()).expect("valid");
    let c = out.compiled;
    assert!(
        !c.diagnostics.iter().any(|d| d.code == Code::AlgebraicLoop),
        "{:?}",
        c.diagnostics
    );
    let space = c.state_space.as_ref().expect("state equations, implicit");
    assert_eq!(space.loops.len(), 1);
    let l = &space.loops[0];
    assert_eq!(l.name, "e_a_r1");
    assert_eq!(l.element, "r3");
    assert!(l.description.contains("`a -> r1`"), "{}", l.description);
    // The loop's unknown u − e_b, and the closing equation, cubic in it.
    let rhs = space.equations[0].1;
    assert!(c
        .exprs
        .leaves(rhs)
        .iter()
        .any(|s| matches!(s, Symbol::Loop(_))));
    assert!(c
        .exprs
        .leaves(l.residual)
        .iter()
        .any(|s| matches!(s, Symbol::Loop(_))));
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
            "ARR1@a: m * C1 * der(v1, 2) - C1 * der(U, 1) + v1 - v2",
            "ARR2@b: U - m * der(v1, 1) - L1 * der(v2, 1)"
        ]
    );
}

#[test]
fn an_unmeasured_mass_between_two_measured_ones_is_eliminated() {
    // F -> m1 (y1 measured) -> spring k1 -> m2 (unmeasured) -> spring k2 -> m3 (y3 measured).
    // By hand, with f1 = F - m1 y1' (mass 1) and f2 = m3 y3' (mass 3):
    //   spring 1: f1' = k1 (y1 - v2), so v2 = y1 - (F' - m1 y1'')/k1;
    //   mass 2:   m2 v2' = f1 - f2, an ARR once v2 is replaced:
    //             F - m1 y1' - m2 y1' + m2 F''/k1 - m1 m2 y1'''/k1 - m3 y3' = 0;
    //   spring 2: f2' = k2 (v2 - y3) with f2 = f1 - m2 v2' (mass 2 again, so that m3 stays
    //             out): y1 - y3 - (F' - m1 y1'')/k1 - (F' - m1 y1'' - m2 v2'')/k2 = 0.
    let d = derive(
        "model t\nparam m1 = 1\nparam m2 = 1.5\nparam m3 = 2\nparam k1 = 40\nparam k2 = 50\ninput F\n\
         Se force = F\nI mass1 = m1\nI mass2 = m2\nI mass3 = m3\nC spring1 stiffness k1\n\
         C spring2 stiffness k2\nDf y1 on v1\nDf y3 on v3\nforce -> 1:v1 -> mass1\n\
         v1 -> 0:f1 -> spring1\nf1 -> 1:v2 -> mass2\nv2 -> 0:f2 -> spring2\nf2 -> 1:v3 -> mass3\n",
    );
    assert_eq!(
        d.arrs,
        [
            "ARR1@v1: m1 * m2 * der(y1, 4) / (k1 * k2) + m1 * der(y1, 2) / k1 + m1 * der(y1, 2) / k2 \
             - m2 * der(F, 3) / (k1 * k2) + m2 * der(y1, 2) / k2 - der(F, 1) / k1 - der(F, 1) / k2 + y1 - y3",
            "ARR2@v3: F - m1 * m2 * der(y1, 3) / k1 - m1 * der(y1, 1) + m2 * der(F, 2) / k1 \
             - m2 * der(y1, 1) - m3 * der(y3, 1)",
        ]
    );
}

#[test]
fn an_inertia_behind_a_rigid_gear_holds_no_state() {
    // T -> J1 -> gear (w2 = w1/N) -> J2 with friction b2. J2 takes derivative causality: its
    // torque is J2 w2' = J2 w1'/N, seen as J2 w1'/N^2 at the motor shaft. By hand, with
    // p = J1 w1: (J1 + J2/N^2) w1' = T - b2 w1/N^2, so
    // p' = (J1 N^2 T - b2 p) / (J1 N^2 + J2): the effective inertia J1 + J2/N^2, one fraction
    // in lowest terms (the nested form T / (1 + J2/(J1 N^2)) - ... is the same value).
    let d = derive(
        "model g\nparam J1 = 0.8\nparam J2 = 10\nparam N = 5\nparam b2 = 2\ninput T\nSe motor = T\n\
         I in1 = J1\nTF gear ratio N\nI in2 = J2\nR fric = b2\nDf w1 on s1\nDf w2 on s2\n\
         motor -> 1:s1 -> in1\ns1 -> gear -> 1:s2 -> in2, fric\n",
    );
    assert_eq!(
        d.states,
        ["p_in1' = (T * J1 * N ^ 2 - p_in1 * b2) / (J1 * N ^ 2 + J2)"]
    );
    assert_eq!(d.outputs, ["w1 = p_in1 / J1", "w2 = p_in1 / (J1 * N)"]);
    assert_eq!(
        d.integral,
        [
            ("in1".into(), StorageCausality::Integral),
            ("in2".into(), StorageCausality::Derivative)
        ]
    );
}

#[test]
fn capacitors_in_parallel_share_one_state() {
    // I0 -> 0 -> C1, C2, R. C2 sees the voltage C1 sets: one state, C = C1 + C2. By hand,
    // v = q1/C1 and (C1 + C2) v' = I0 - v/R, so q1' = C1 v' = (C1 I0 - q1/R)/(C1 + C2).
    let d = derive(
        "model p\nparam C1 = 2e-3\nparam C2 = 3e-3\nparam R1 = 100\ninput I0\nSf src = I0\n\
         C c1 = C1\nC c2 = C2\nR load = R1\nDe v on n\nsrc -> 0:n -> c1, c2, load\n",
    );
    assert_eq!(d.states, ["q_c1' = (I0 * C1 - q_c1 / R1) / (C1 + C2)"]);
    assert_eq!(d.outputs, ["v = q_c1 / C1"]);
}

#[test]
fn inductors_in_series_share_one_state() {
    // U -> 1 -> L1, L2, R: one current, L = L1 + L2. p1 = L1 i, (L1 + L2) i' = U - R i, so
    // p1' = (L1 U - R p1)/(L1 + L2).
    let d = derive(
        "model s\nparam L1 = 0.1\nparam L2 = 0.3\nparam R1 = 5\ninput U\nSe src = U\nI l1 = L1\n\
         I l2 = L2\nR r = R1\nDf i on j\nsrc -> 1:j -> l1, l2, r\n",
    );
    assert_eq!(d.states, ["p_l1' = (U * L1 - p_l1 * R1) / (L1 + L2)"]);
}

/// The operator that `expr` (linear in the signals, constant coefficients) applies, read at
/// d/dt = `s` with each signal's amplitude given by `amplitude`: `Σ P_sig(s) X_sig`.
fn at_frequency(
    c: &Compiled,
    expr: bondgraph_core::Expr,
    s: f64,
    amplitude: &dyn Fn(&str) -> f64,
) -> f64 {
    let mut eval = Evaluator::new(&c.exprs, |sym: Symbol| match sym {
        Symbol::Parameter(p) => c.parameters[p].value,
        Symbol::Input(u, k) => s.powi(k as i32) * amplitude(&c.inputs[u].name),
        Symbol::Sensor(h, k) => s.powi(k as i32) * amplitude(&c.sensors[h].name),
        Symbol::State(_)
        | Symbol::Auxiliary(..)
        | Symbol::Time
        | Symbol::Loop(_)
        | Symbol::Root(..) => f64::NAN,
    });
    eval.value(expr)
}

#[test]
fn four_masses_with_two_unmeasured_give_arrs_of_least_order() {
    // models/four_mass_chain.bg: F -> m1 (y1) -k1,b1- m2 -k2,b2- m3 -k3,b3- m4 (y4), each
    // spring in parallel with its damper: f_i = (k_i/s + b_i)(v_i - v_i+1) with s = d/dt.
    // ARR1 by hand, along mass 1, spring 1, mass 2, spring 2, mass 3 to mass 4 (spring 3
    // left out): f1 = F - m1 s y1, v2 = y1 - s f1/(b1 s + k1), f2 = f1 - m2 s v2,
    // v3 = v2 - s f2/(b2 s + k2), f3 = f2 - m3 s v3, and f3 - m4 s y4 = 0. Cleared of its
    // denominators by (1 + b1 s/k1)(1 + b2 s/k2): order 5 in y1, 4 in F, 3 in y4. Eliminating
    // the two unknown forces one after the other without the operators' common factor
    // multiplies it once more by (1 + b1 s/k1): order 6, one derivative more of every signal.
    // ARR2 by hand, along mass 4 and spring 3 from the other end (mass 3 left out):
    // f3 = m4 s y4, v3 = y4 + s f3/(b3 s + k3), and spring 2, f2 = (k2/s + b2)(v2 - v3), with
    // f2 and v2 from the left as above. Cleared of its denominators, s f2 - (b2 s + k2)
    // (v2 - v3) times (1 + b1 s/k1)(1 + b3 s/k3), scaled by -1/k2: order 5 in y1, 4 in F, y4.
    let c = model("four_mass_chain.bg");
    let p = |n: &str| value_of(&c, n);
    let (m1, m2, m3, m4) = (p("m1"), p("m2"), p("m3"), p("m4"));
    let (k1, k2, k3, b1, b2, b3) = (p("k1"), p("k2"), p("k3"), p("b1"), p("b2"), p("b3"));
    let max_order = |e| {
        let mut top = 0;
        c.exprs.visit_reachable(&[e], |_, node| {
            if let bondgraph_core::Node::Leaf(Symbol::Sensor(_, k) | Symbol::Input(_, k)) = node {
                top = top.max(k);
            }
        });
        top
    };
    assert_eq!(max_order(c.arrs[0].expr), 5);
    assert_eq!(max_order(c.arrs[1].expr), 5);
    for (s, xf, x1, x4) in [
        (0.3, 1.0, 0.7, -0.4),
        (-1.7, 0.2, 2.0, 1.1),
        (2.9, -0.5, 0.3, 0.8),
    ] {
        let amplitude = |n: &str| match n {
            "F" => xf,
            "y1" => x1,
            "y4" => x4,
            _ => f64::NAN,
        };
        let f1 = xf - m1 * s * x1;
        let v2 = x1 - s * f1 / (b1 * s + k1);
        let f2 = f1 - m2 * s * v2;
        let v3 = v2 - s * f2 / (b2 * s + k2);
        let f3 = f2 - m3 * s * v3;
        let arr1 = (1.0 + b1 * s / k1) * (1.0 + b2 * s / k2) * (f3 - m4 * s * x4);
        let got = at_frequency(&c, c.arrs[0].expr, s, &amplitude);
        assert!(
            (got - arr1).abs() <= 1e-9 * arr1.abs().max(1.0),
            "ARR1 at s = {s}: {got} against {arr1}"
        );
        // ARR2 is spring 2's balance times an operator: the same ratio at another mix of the
        // signals, and that ratio is the clearing factor above.
        let v3_right = x4 + s * m4 * s * x4 / (b3 * s + k3);
        let spring2 = f2 - (k2 / s + b2) * (v2 - v3_right);
        let got2 = at_frequency(&c, c.arrs[1].expr, s, &amplitude);
        let ratio = got2 / spring2;
        let other = |n: &str| {
            amplitude(n) * if n == "y4" { 2.0 } else { 1.0 } + if n == "F" { 0.5 } else { 0.0 }
        };
        let f1 = other("F") - m1 * s * other("y1");
        let v2 = other("y1") - s * f1 / (b1 * s + k1);
        let f2 = f1 - m2 * s * v2;
        let v3_right = other("y4") + s * m4 * s * other("y4") / (b3 * s + k3);
        let spring2_other = f2 - (k2 / s + b2) * (v2 - v3_right);
        let got2_other = at_frequency(&c, c.arrs[1].expr, s, &other);
        assert!(
            (got2_other - ratio * spring2_other).abs() <= 1e-9 * got2_other.abs().max(1.0),
            "ARR2 at s = {s} is not spring 2's balance: {got2_other} against {}",
            ratio * spring2_other
        );
        let clearing = -(1.0 + b1 * s / k1) * (1.0 + b3 * s / k3) * s / k2;
        assert!(
            (ratio / clearing - 1.0).abs() < 1e-9,
            "ARR2's factor at s = {s}: {ratio} against {clearing}"
        );
    }
}

/// A model of `models/`, compiled with canonical forms.
fn model(file: &str) -> Compiled {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(file);
    compiled(&std::fs::read_to_string(path).expect("model"))
}

/// A parameter's nominal value.
fn value_of(c: &Compiled, name: &str) -> f64 {
    c.parameters
        .values()
        .find(|p| p.name == name)
        .map(|p| p.value)
        .expect("parameter")
}

#[test]
fn the_bridge_state_equations_are_one_fraction_in_lowest_terms() {
    // models/wheatstone_bridge.bg: C1 v1' = I0 - i, C2 v2' = i - v2/RL, with i the current
    // the bridge carries from node a to node b. By hand (nodal analysis of the inner nodes c
    // and d, solved here numerically): (v1 - vc)/Ra = (vc - v2)/Rc + (vc - vd)/Rm and
    // (v1 - vd)/Rb + (vc - vd)/Rm = (vd - v2)/Rd, i = (v1 - vc)/Ra + (v1 - vd)/Rb.
    // Solved one torn unknown at a time, the right-hand sides were fractions nested three deep
    // (over 3,000 characters); in lowest terms they are one numerator over the bridge's
    // determinant.
    let c = model("wheatstone_bridge.bg");
    let printer = Printer::new(&c.exprs, |s| name(&c, s));
    let space = c.state_space.as_ref().expect("state equations");
    let p = |n: &str| value_of(&c, n);
    let (ra, rb, rc, rd, rm, rl) = (p("Ra"), p("Rb"), p("Rc"), p("Rd"), p("Rm"), p("RL"));
    let (c1, c2) = (p("C1"), p("C2"));
    for (_, rhs) in &space.equations {
        let shown = printer.text(*rhs);
        // Canonical (no rewriting): about 1,000 characters, expanded over the determinant.
        assert!(shown.len() < 1_200, "not in lowest terms: {shown}");
    }
    for (q1, q2, i0) in [(2e-3, 1e-3, 0.5), (-1e-3, 4e-3, 2.0)] {
        let (v1, v2) = (q1 / c1, q2 / c2);
        // [1/Ra + 1/Rc + 1/Rm, -1/Rm; -1/Rm, 1/Rb + 1/Rd + 1/Rm] [vc; vd] = [v1/Ra + v2/Rc; v1/Rb + v2/Rd]
        let (a11, a12, a22) = (
            1.0 / ra + 1.0 / rc + 1.0 / rm,
            -1.0 / rm,
            1.0 / rb + 1.0 / rd + 1.0 / rm,
        );
        let (b1, b2) = (v1 / ra + v2 / rc, v1 / rb + v2 / rd);
        let det = a11 * a22 - a12 * a12;
        let (vc, vd) = ((b1 * a22 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        let i = (v1 - vc) / ra + (v1 - vd) / rb;
        let expected = [i0 - i, i - v2 / rl];
        let mut eval = Evaluator::new(&c.exprs, |s: Symbol| match s {
            Symbol::Parameter(h) => c.parameters[h].value,
            Symbol::Input(_, 0) => i0,
            Symbol::State(k) if c.states[k].element == "cap1" => q1,
            Symbol::State(_) => q2,
            _ => f64::NAN,
        });
        for ((_, rhs), want) in space.equations.iter().zip(expected) {
            let got = eval.value(*rhs);
            assert!(
                (got - want).abs() <= 1e-12 * want.abs().max(1e-9),
                "{got} against {want}"
            );
        }
    }
}

#[test]
fn the_bridge_gives_a_bridge_free_arr_and_an_exact_fsm() {
    // Each node's balance holds the whole bridge; their sum, the total current balance, holds
    // none of it: all current into the bridge leaves it at node b. With both voltages measured
    // the ARRs are node a's balance and C1 v1' + C2 v2' + v2/RL = I0, and a fault of the
    // bridge moves the first only.
    let c = model("wheatstone_bridge.bg");
    let printer = Printer::new(&c.exprs, |s| name(&c, s));
    let texts: Vec<String> = c.arrs.iter().map(|a| printer.text(a.expr)).collect();
    assert_eq!(texts[1], "I0 - C1 * der(v1, 1) - C2 * der(v2, 1) - v2 / RL");
    let marked = |arr: usize| -> Vec<&str> {
        c.components
            .values()
            .filter(|k| k.marks.contains(&arr))
            .map(|k| k.name.as_str())
            .collect()
    };
    assert_eq!(marked(1), ["src", "cap1", "cap2", "load", "v1", "v2"]);
    assert_eq!(
        marked(0),
        ["src", "cap1", "ra", "rb", "rc", "rd", "rm", "v1", "v2"]
    );
}
