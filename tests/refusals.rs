//! Output that is right or refused: stage failures are located diagnostics in the user's
//! names with exit 1, nothing implausible is printed, inputs never hang, and the same model
//! gives the same bytes whatever the limits.

use std::io::Write as _;
use std::process::{Command, Stdio};

use crate::common::{bgc, code, root, scratch, stderr, stdout};

/// Runs bgc on `text` given on standard input.
fn bgc_stdin(args: &[&str], text: &[u8]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bgc"))
        .args(args)
        .current_dir(root())
        .env("NO_COLOR", "1")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("bgc runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(text)
        .expect("written");
    child.wait_with_output().expect("bgc ends")
}

/// Words that must never reach standard output.
fn assert_plausible(text: &str) {
    for word in ["NaN", "inf", "unknown", "Var(", "Tear("] {
        let bare = text
            .split(|c: char| !c.is_alphanumeric() && c != '(' && c != '_')
            .any(|w| w == word);
        assert!(!bare, "output holds `{word}`:\n{text}");
    }
}

const CONFLICT: &str = "model conflict\nparam R1 = 2\ninput U\ninput V\n\
    Se a = U\nSe b = V\nR r = R1\nDe v on n\na -> 0:n -> r\nb -> n\n";

#[test]
fn a_causal_conflict_is_reported_in_user_names_with_exit_1() {
    for emit in ["state", "text", "json", "latex"] {
        let out = bgc_stdin(&["-", "--emit", emit], CONFLICT.as_bytes());
        assert_eq!(code(&out), 1, "--emit {emit}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(err.contains("bg::causal-conflict"), "{err}");
        assert!(err.contains("<stdin>:"), "located: {err}");
        assert_eq!(
            err.matches("causal conflict at").count(),
            1,
            "reported once: {err}"
        );
        for internal in ["unknown", " e1", " f2", "Var"] {
            assert!(!err.contains(internal), "internal name {internal}: {err}");
        }
        assert_plausible(&stdout(&out));
    }
    let json = stdout(&bgc_stdin(&["-", "--emit", "json"], CONFLICT.as_bytes()));
    assert!(json.contains("\"state_equations\": null"), "{json}");
    assert!(json.contains("\"code\": \"bg::causal-conflict\""), "{json}");
    assert!(json.contains("\"line\": "), "{json}");
}

#[test]
fn a_model_without_state_equations_cannot_be_verified() {
    let out = bgc_stdin(&["verify", "-"], CONFLICT.as_bytes());
    assert_eq!(code(&out), 1);
    assert!(
        stderr(&out).contains("bg::causal-conflict"),
        "{}",
        stderr(&out)
    );
    assert!(stdout(&out).is_empty(), "{}", stdout(&out));
}

#[test]
fn a_nonlinear_algebraic_loop_is_held_implicitly_and_verify_goes_through_it() {
    let text = "model nl\nparam R1 = 2\nparam C1 = 3\ninput U\nSe u = U\nR r1 : f = e^3\n\
        R r2 = R1\nR r3 = C1\nC cap = C1\nDf y on c\nDe yb on b\nu -> 1:a -> r1\n\
        a -> 0:b -> r2\nb -> 1:c -> r3, cap\n";
    let out = bgc_stdin(&["-", "--emit", "state"], text.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let printed = stdout(&out);
    assert!(
        printed.contains("der(q_cap) = (e_a_r1 - U) / R1 + e_a_r1 ^ 3"),
        "{printed}"
    );
    assert!(printed.contains("solved numerically"), "{printed}");
    assert!(
        printed.contains("0 = U + U * C1 / R1 - e_a_r1"),
        "{printed}"
    );
    assert_plausible(&printed);
    // Newton's method solves the loop's unknown wherever the plant is evaluated, and its
    // derivative comes from its own equation: every ARR and entry is checked.
    let out = bgc_stdin(&["verify", "-"], text.as_bytes());
    assert_eq!(code(&out), 0, "{}{}", stdout(&out), stderr(&out));
    assert!(
        stdout(&out).contains("passed: 2 ARRs, 12 FSM entries checked, 0 failed"),
        "{}",
        stdout(&out)
    );
}

#[test]
fn a_let_that_doubles_at_every_step_is_refused_before_it_is_expanded() {
    let mut text = String::from(
        "model deep\nparam a = 0.5\nparam R1 = 2\nparam C1 = 1\ninput U\nlet l0 = U\n",
    );
    for i in 1..200 {
        text.push_str(&format!("let l{i} = l{}*l{} + a\n", i - 1, i - 1));
    }
    text.push_str("MSe u = l199\nR r = R1\nC c = C1\nDf i on j\nu -> 1:j -> r, c\n");
    // Expanded, the last `let` would hold 2^199 terms: the refusal names the first that
    // passes the bound, so it is found from the sizes alone (no clock is asked).
    let out = bgc_stdin(&["-"], text.as_bytes());
    assert_eq!(code(&out), 1);
    let err = stderr(&out);
    assert!(
        err.contains("bg::too-large") && err.contains("`l16`"),
        "{err}"
    );
    assert_plausible(&stdout(&out));
    // The model itself is valid: `check` accepts it at once.
    let out = bgc_stdin(&["check", "-"], text.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
}

/// A high derivative of a product of functions (each order nearly doubles it) is refused at
/// the order whose nodes pass the bound, before any other stage: `der()` of eight functions
/// to order 16 took 64 CPU-seconds and 1.3 GB before being refused as too large to print.
/// Order 8 of the same product is derived.
#[test]
fn a_derivative_that_grows_past_the_bound_is_refused_as_it_grows() {
    let model = |n: u32| {
        format!(
            "model der16\nparam R1 = 10\nparam L1 = 0.1\ninput V\n\
             let g = sin(V)*cos(V)*exp(V)*tanh(V)*atan(V)*sqrt(V)*log(V)*abs(V)\n\
             Se src = der(g, {n})\nR res = R1\nI ind = L1\nDf i on loop\n\
             src -> 1:loop -> res, ind\n"
        )
    };
    let out = bgc_stdin(&["-", "--emit", "json"], model(16).as_bytes());
    assert_eq!(code(&out), 1);
    let err = stderr(&out);
    assert!(
        err.contains("bg::too-large")
            && err.contains("<stdin>:6:4")
            && err.contains("the `der(…, 16)` in `src`'s law passes bgc's bound of 50000 expression nodes at order 13"),
        "{err}"
    );
    assert_plausible(&stdout(&out));
    let out = bgc_stdin(&["-", "--emit", "json"], model(8).as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
}

#[test]
fn standard_input_and_a_byte_order_mark_are_accepted() {
    let text = std::fs::read("models/dc_motor.bg")
        .or_else(|_| std::fs::read(root().join("models/dc_motor.bg")))
        .expect("model");
    let from_file = bgc(&["models/dc_motor.bg"]);
    let mut with_bom = b"\xEF\xBB\xBF".to_vec();
    with_bom.extend(&text);
    for input in [text.clone(), with_bom] {
        let out = bgc_stdin(&["-"], &input);
        assert_eq!(code(&out), 0, "{}", stderr(&out));
        assert_eq!(stdout(&out), stdout(&from_file));
        assert!(stderr(&out).is_empty(), "{}", stderr(&out));
    }
}

#[test]
fn a_model_without_detectors_says_it_has_no_arrs() {
    let text = "model rc\nparam R1 = 2\nparam C1 = 3\ninput U\nSe u = U\nR r = R1\nC c = C1\nu -> 1:j -> r, c\n";
    let out = bgc_stdin(&["-"], text.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(
        stdout(&out).contains("the model has no detectors"),
        "{}",
        stdout(&out)
    );
}

#[test]
fn the_fsm_columns_are_the_arr_names() {
    let out = bgc(&["models/dc_motor.bg"]);
    assert!(
        stdout(&out).contains("Db  Ib  ARR1  ARR2"),
        "{}",
        stdout(&out)
    );
}

/// The clock never decides what is printed: 8 runs of the bench give the same bytes for
/// every emitter, and under other limits (fewer runs, to keep the test short) too. A run
/// paused past the old `--egg-seconds` (10 s, under load) once failed a shipped model.
#[test]
fn repeated_runs_of_the_bench_are_byte_identical_under_any_limits() {
    // 8 runs of the default, 2 under each other limit (once 20 and 3): the mutation test runs
    // CLI mutants twice as well (tests/mutations.rs).
    let limits: [(&[&str], usize); 4] = [
        (&[], 8),
        (&["--canonical"], 2),
        (&["--egg-nodes", "300", "--egg-iterations", "3"], 2),
        (&["--egg-rounds", "1", "--egg-budget", "3000"], 2),
    ];
    let emitters = ["text", "json", "latex", "state", "dot", "rust", "c"];
    for (extra, runs) in limits {
        for emit in emitters {
            let mut args = vec!["models/backlash_bench.bg", "--emit", emit];
            args.extend_from_slice(extra);
            let first = bgc(&args);
            assert_eq!(code(&first), 0, "{args:?}: {}", stderr(&first));
            for _ in 1..runs {
                let again = bgc(&args);
                assert_eq!(code(&again), 0, "{args:?}");
                assert_eq!(again.stdout, first.stdout, "{args:?}");
            }
        }
    }
}

/// A hardening spring written as the physics gives it, `e = k1 q + k3 q³`, with a speed
/// sensor on the mass: the law has no closed-form inverse, so the ARR holds the stretch as a
/// root of the law, solved at each sample, and reads no integral (it read `int(v)` from the
/// start of the record, with a warning, before): exit 0, residual code that solves it, and
/// `bgc verify` passes from a start where the spring is stretched.
const HARDENING: &str = "model hardening\nparam m = 1.0\nparam k1 = 40\nparam k3 = 400\n\
    param b = 0.5\ninput F\nSe force = F\nI mass = m\nC spring : e = k1*q + k3*q^3\n\
    R damp = b\nDf v on v1\nforce -> 1:v1 -> mass, spring, damp\n";

#[test]
fn a_storage_law_with_no_closed_form_inverse_is_solved_as_a_root() {
    let out = bgc_stdin(&["-"], HARDENING.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(
        !stderr(&out).contains("bg::mixed-causality"),
        "{}",
        stderr(&out)
    );
    let text = stdout(&out);
    assert!(!text.contains("int(v)"), "{text}");
    assert!(
        text.contains("where q_spring is the root of k1 * q_spring + k3 * q_spring ^ 3 - (F - der(v) * m - b * v) = 0"),
        "{text}"
    );
    assert!(text.contains("spring     derivative"), "{text}");
    let rust = bgc_stdin(&["-", "--emit", "rust"], HARDENING.as_bytes());
    assert_eq!(code(&rust), 0, "{}", stderr(&rust));
    let rust = stdout(&rust);
    assert!(
        rust.contains("pub fn residuals") && rust.contains("RootFinder"),
        "{rust}"
    );
    let c = bgc_stdin(&["-", "--emit", "c"], HARDENING.as_bytes());
    assert_eq!(code(&c), 0, "{}", stderr(&c));
    let c = stdout(&c);
    assert!(
        c.contains("bgc_root_solve(&g->roots[0], hardening_law0") && c.contains("\"q_spring\""),
        "{c}"
    );
    let json = stdout(&bgc_stdin(&["-", "--emit", "json"], HARDENING.as_bytes()));
    assert!(
        json.contains("\"roots\": [{\"name\": \"q_spring\", \"element\": \"spring\""),
        "{json}"
    );
    // The spring no longer keeps integral causality in diagnosis, so verify's runs start it
    // stretched, where an ARR that read int(v) would not hold.
    let verify = bgc_stdin(&["verify", "-"], HARDENING.as_bytes());
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// A law that reaches its variable through `abs` (`e = k0 q + k1 |q| q`) has flat stretches or
/// several roots in general, so it is not solved numerically: the spring keeps integral
/// causality in diagnosis, with a warning saying what the ARR assumes, not an error.
const ABS_SPRING: &str = "model absspring\nparam m = 1.0\nparam k0 = 40\nparam k1 = 400\n\
    param b = 0.5\ninput F\nSe force = F\nI mass = m\nC spring : e = k0*q + k1*abs(q)*q\n\
    R damp = b\nDf v on v1\nforce -> 1:v1 -> mass, spring, damp\n";

#[test]
fn a_storage_law_diagnosis_cannot_solve_is_a_note_not_an_error() {
    let out = bgc_stdin(&["-"], ABS_SPRING.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("bg::mixed-causality") && err.contains("int(..)"),
        "{err}"
    );
    assert!(stdout(&out).contains("int(v)"), "{}", stdout(&out));
    let verify = bgc_stdin(&["verify", "-"], ABS_SPRING.as_bytes());
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// A gas accumulator written as the physics gives it, `q = V0 (1 − p0/e)`: the law serves
/// both causalities, as written for the ARR and through its closed-form inverse for the
/// state equations, whose state is the liquid volume `q`; the output states the inverse and
/// where it holds.
const ACCUMULATOR: &str = "model accumulator\nparam V0 = 1e-3\nparam p0 = 1e5\n\
    param R1 = 1e8\ninput Q\nSf pump = Q\nC acc : q = V0*(1 - p0/e)\nR valve = R1\n\
    De p on n\npump -> 0:n -> acc, valve\n";

#[test]
fn a_storage_law_given_from_its_effort_serves_both_causalities() {
    let out = bgc_stdin(&["-"], ACCUMULATOR.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    for expected in [
        "der(q_acc) =",
        "acc        law read the other way: e = p0 / (1 - q / V0), where 1 - q / V0 != 0",
        "Q - V0 * p0 * der(p) / p ^ 2 - p / R1 = 0",
    ] {
        assert!(text.contains(expected), "{expected}:\n{text}");
    }
    let verify = bgc_stdin(
        &["verify", "-", "--state-scale", "1e-4"],
        ACCUMULATOR.as_bytes(),
    );
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// A capacitor whose charge follows its voltage with no closed-form inverse,
/// `q = C0 e + C1 e³`: the state equations hold its voltage, `de/dt = f / (C0 + 3 C1 e²)`.
const VARACTOR: &str = "model varactor\nparam C0 = 1e-3\nparam C1 = 1e-4\nparam R1 = 10\n\
    input U\nSe src = U\nR res = R1\nC cap : q = C0*e + C1*e^3\nDf i on j\n\
    src -> 1:j -> res, cap\n";

#[test]
fn a_storage_law_without_inverse_holds_its_co_energy_variable() {
    let out = bgc_stdin(&["-"], VARACTOR.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("der(e_cap) = 1/3 * (U - e_cap) / R1 / (e_cap ^ 2 * C1 + 1/3 * C0)"),
        "{text}"
    );
    let verify = bgc_stdin(&["verify", "-"], VARACTOR.as_bytes());
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// The orifice law as the language reference writes it, `f = c sqrt(e)`, with only a flow
/// meter: its inverse `e = (f/c)^2` (for `f/c >= 0`) gives the tank's ARR, which was missing.
const ORIFICE: &str = "model orifice\nparam A = 0.01\nparam rho = 1000\nparam g = 9.81\n\
    param c = 1e-5\ninput Q\nSf pump = Q\nC tank = A/(rho*g)\nR drain : f = c*sqrt(e)\n\
    Df q on d\npump -> 0:a -> tank\na -> 1:d -> drain\n";

#[test]
fn the_orifice_law_as_written_gives_the_flow_meters_arr() {
    let out = bgc_stdin(&["-"], ORIFICE.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    for expected in [
        "der(q_tank) = Q - c * sqrt(q_tank * rho * g / A)",
        "drain      law read the other way: e = (f / c) ^ 2, where f / c >= 0",
        "Q - q * 2 * A * der(q) / rho / c ^ 2 / g - q = 0",
    ] {
        assert!(text.contains(expected), "{expected}:\n{text}");
    }
    assert!(!stderr(&out).contains("bg::no-arr"), "{}", stderr(&out));
}

/// Enthalpy leaving a volume with an input mass flow, `f = cp w e`: a plain `R` may not read
/// the input (and says to write `MR`), an `MR` may.
#[test]
fn a_law_that_reads_an_input_is_a_modulated_element() {
    let model = |kind: &str| {
        format!(
            "model outflow\nparam cp = 4186\nparam M = 5\ninput w\ninput Qh\nSf heater = Qh\n\
             C water = M*cp\n{kind} out : f = cp*w*e\nDe T on th\nheater -> 0:th -> water, out\n"
        )
    };
    let plain = bgc_stdin(&["-"], model("R").as_bytes());
    assert_eq!(code(&plain), 1);
    assert!(
        stderr(&plain).contains("write MR instead of"),
        "{}",
        stderr(&plain)
    );
    let modulated = bgc_stdin(&["-"], model("MR").as_bytes());
    assert_eq!(code(&modulated), 0, "{}", stderr(&modulated));
    let text = stdout(&modulated);
    assert!(
        text.contains("der(q_water) = Qh - q_water * w / M"),
        "{text}"
    );
    assert!(
        text.contains("Qh - cp * (w * T + M * der(T)) = 0"),
        "{text}"
    );
}

/// A modulated resistor that reads its own junction's flow meter is no state-space model
/// (the reading depends on itself): the state equations are refused, exit 1, and the ARR and
/// its residual code are written all the same.
const SELF_READING: &str = "model selfread\nparam k = 2\nparam C1 = 1\ninput U\nSe src = U\n\
    MR r : f = k*i*e\nC c = C1\nDf i on j\nsrc -> 1:j -> r, c\n";

#[test]
fn refused_state_equations_leave_the_residual_code() {
    let out = bgc_stdin(&["-", "--emit", "rust"], SELF_READING.as_bytes());
    assert_eq!(code(&out), 1, "the state equations are refused");
    assert!(
        stderr(&out).contains("bg::refused") && stderr(&out).contains("signal(s) `i`, which"),
        "{}",
        stderr(&out)
    );
    let rust = stdout(&out);
    assert!(
        rust.contains("pub fn residuals") && rust.contains("p.C1"),
        "{rust}"
    );
    assert_plausible(&rust);
    let out = bgc_stdin(&["-", "--emit", "c"], SELF_READING.as_bytes());
    assert_eq!(code(&out), 1, "the state equations are refused");
    let c = stdout(&out);
    assert!(
        c.contains("void selfread_residuals(") && c.contains("p->C1"),
        "{c}"
    );
    assert_plausible(&c);
}

/// One mass `m` in two inertias (a cart and the pendulum's bob moving with it) and the weight:
/// a change of `m` faults all three at once, which no FSM row shows. A warning names them, and
/// the output lists where a change of `m` can show: the union of their rows.
const SHARED: &str = "model shared\nparam m = 2\nparam b = 0.5\nparam g = 9.81\ninput F\n\
    Se push = F\nSe weight = m*g\nI cart = m\nI bob = m\nR damp = b\nDf v on v1\nDf w on v2\n\
    push -> 1:v1 -> cart, damp\nv1 -> 0:n\nn -> 1:v2 -> bob\nweight -> v2\n";

#[test]
fn a_parameter_several_components_read_is_named_with_where_it_can_show() {
    let out = bgc_stdin(&["-"], SHARED.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("bg::shared-parameter")
            && err.contains("`m` is a parameter of `weight`, `cart` and `bob`"),
        "{err}"
    );
    let text = stdout(&out);
    assert!(text.contains("shared parameters"), "{text}");
    assert!(text.contains("  m  weight cart bob  ->  "), "{text}");
    let json = bgc_stdin(&["-", "--emit", "json"], SHARED.as_bytes());
    assert!(
        stdout(&json).contains(
            "\"shared\": [{\"parameter\": \"m\", \"components\": [\"weight\", \"cart\", \"bob\"]"
        ),
        "{}",
        stdout(&json)
    );
}

/// A load whose inertia law is nonlinear, `f = p/Jl + a3 p³`: the state equations hold `p`
/// as written; diagnosis solves it for `p` numerically, as a root of the law, where it fell
/// back to integral causality (and `int(w)`) before.
const CUBIC_INERTIA: &str = "model cubic\nparam Jl = 0.1\nparam a3 = 0.01\nparam b = 0.05\n\
    input T\nSe motor = T\nI load : f = p/Jl + a3*p^3\nR fric = b\nDf w on s\n\
    motor -> 1:s -> load, fric\n";

#[test]
fn a_nonlinear_inertia_is_solved_for_its_momentum() {
    let out = bgc_stdin(&["-"], CUBIC_INERTIA.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(stderr(&out).is_empty(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("where p_load is the root of p_load / Jl + a3 * p_load ^ 3 - w = 0"),
        "{}",
        stdout(&out)
    );
    let text = stdout(&out);
    assert!(
        text.contains("der(p_load) = T - b * (p_load ^ 3 * a3 + p_load / Jl)"),
        "{text}"
    );
    let verify = bgc_stdin(&["verify", "-"], CUBIC_INERTIA.as_bytes());
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// A ring of three tanks, two joined by orifices and the third back to the first through a
/// check valve smoothed by `tanh`, with the first level and the two orifices' flows
/// measured: the orifices' laws read the other way give the other levels, and each of the
/// three detectors its ARR (there were none).
const RING: &str = "model ring\nparam Cd1 = 1.5e-6\nparam Cd2 = 1.2e-6\nparam Ck = 1e-6\n\
    param p0 = 100\nparam A = 0.0154\nparam rho = 1000\nparam g = 9.81\ninput Q\nSf pump = Q\n\
    C t1 = A/(rho*g)\nC t2 = A/(rho*g)\nC t3 = A/(rho*g)\n\
    R o12 : f = Cd1*sign(e)*sqrt(abs(e))\nR o23 : f = Cd2*sign(e)*sqrt(abs(e))\n\
    R chk : f = Ck*(1 + tanh(e/p0))*sqrt(abs(e))/2\nDe p1 on n1\nDf q12 on j12\nDf q23 on j23\n\
    pump -> 0:n1 -> t1\nn1 -> 1:j12 -> o12\nj12 -> 0:n2 -> t2\nn2 -> 1:j23 -> o23\n\
    j23 -> 0:n3 -> t3\nn3 -> 1:j31 -> chk\nj31 -> n1\n";

#[test]
fn a_ring_of_tanks_with_a_smoothed_check_valve_has_its_arrs() {
    let out = bgc_stdin(&["-"], RING.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    for arr in ["ARR1 (", "ARR2 (", "ARR3 ("] {
        assert!(text.contains(arr), "{arr}:\n{text}");
    }
    assert!(
        // No `where abs(f) / Cd1 >= 0`: with a positive coefficient it always holds.
        text.contains("o12        law read the other way: e = sign(f) * (abs(f) / Cd1) ^ 2\n"),
        "{text}"
    );
    assert!(!stderr(&out).contains("bg::no-arr"), "{}", stderr(&out));
}

/// A spring whose force saturates, `e = k (tanh q + atan(q)/10)`: the law has no closed-form
/// inverse and no root beyond `±1.16 k`. On a record whose force leaves that range, the
/// estimates there are flagged (the `unsolved` column names the root, standard error counts
/// them), never given a guessed stretch; within the range the residual is a number.
const SATURATING: &str = "model saturating\nparam m = 1.0\nparam k = 40\nparam b = 0.5\n\
    input F\nSe force = F\nI mass = m\nC spring : e = k*(tanh(q) + atan(q)/10)\nR damp = b\n\
    Df v on v1\nforce -> 1:v1 -> mass, spring, damp\n";

#[test]
fn a_sample_where_a_law_has_no_root_is_flagged_not_guessed() {
    let dir = scratch("unsolved");
    let model = dir.join("saturating.bg");
    std::fs::write(&model, SATURATING).expect("model");
    // At rest, F within the spring's range for a second, then far beyond it.
    let mut csv = String::from("t,F,v\n");
    for k in 0..2000 {
        let t = f64::from(k) * 1e-3;
        let force = if t < 1.0 { 10.0 } else { 100.0 };
        csv.push_str(&format!("{t},{force},0\n"));
    }
    let record = dir.join("record.csv");
    std::fs::write(&record, csv).expect("record");
    let model = model.to_string_lossy().into_owned();
    let record = record.to_string_lossy().into_owned();
    let out = bgc(&["residuals", &model, &record]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    // After the episode, before the three size columns.
    assert_eq!(header[header.len() - 4], "unsolved", "{header:?}");
    let (mut flagged, mut solved) = (0, 0);
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let t: f64 = cells[0].parse().expect("time");
        let unsolved = cells[cells.len() - 4];
        if t < 0.9 {
            assert_eq!(unsolved, "", "{line}");
            assert!(cells[1].parse::<f64>().is_ok_and(f64::is_finite), "{line}");
            solved += 1;
        } else if t > 1.1 {
            assert_eq!(unsolved, "q_spring", "{line}");
            flagged += 1;
        }
    }
    assert!(
        solved > 100 && flagged > 100,
        "{solved} solved, {flagged} flagged"
    );
    assert!(
        stderr(&out).contains("`q_spring` has no root at"),
        "{}",
        stderr(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The bench with a torque sensor on the twist (`De zz_new on twist`): the shafts' ARRs no
/// longer use the link's law, yet read its stiffness K inside the dead zone `w`, and the
/// motor side's the gear's N inside the twist. The FSM marks the link there (it did not,
/// with exit 0, and `bgc verify` failed it), and the shared N lists that ARR, so `bgc
/// verify` passes.
#[test]
fn a_parameter_read_through_another_law_marks_its_component() {
    let text = std::fs::read_to_string(root().join("models/backlash_bench.bg")).expect("bench")
        + "De zz_new on twist\n";
    let out = bgc_stdin(&["-"], text.as_bytes());
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let table = stdout(&out);
    let link = table
        .lines()
        .find(|l| l.split_whitespace().take(2).eq(["link", "C"]))
        .expect("link's row");
    let cells: Vec<&str> = link.split_whitespace().collect();
    // ARR1 (motor side) and ARR3 (load side) read K inside `w`, ARR2 is the link's law.
    assert_eq!(&cells[4..7], ["1", "1", "1"], "{link}");
    assert!(table.contains("N  gear Wl  ->  ARR1 ARR2 ARR3"), "{table}");
    let verify = bgc_stdin(&["verify", "-"], text.as_bytes());
    assert_eq!(code(&verify), 0, "{}", stdout(&verify));
}

/// A scenario's input that divides by what is 0 whatever the time (`(t-t)/(t-t)`) once ran
/// as `U0 = 0`; a value that is not a finite number was printed as it came. Both are refused
/// at the expression, with its line and column.
#[test]
fn a_scenario_dividing_by_zero_is_refused_where_it_is_written() {
    for (statement, said, column) in [
        ("input U0 = (t-t)/(t-t)", "a division by zero", 19),
        ("input U0 = 2 + 0/0", "a division by zero", 18),
        (
            "input U0 = sqrt(-1) * t",
            "`sqrt(-1)` is not a finite number",
            12,
        ),
    ] {
        let out = bgc(&[
            "simulate",
            "models/dc_motor.bg",
            "-e",
            "duration 1",
            "-e",
            "step 0.01",
            "-e",
            statement,
        ]);
        let said_it = stderr(&out);
        assert_eq!(code(&out), 1, "{statement}: {said_it}");
        assert!(said_it.contains(said), "{statement}: {said_it}");
        assert!(
            said_it.contains(&format!(":3:{column}")),
            "{statement}: {said_it}"
        );
        assert!(stdout(&out).is_empty(), "{statement}: printed a record");
    }
}

/// Names, units and error columns past 65,535 characters once made `format!` panic (exit
/// 101, "Formatting argument out of range") in `check`, `--emit text`, `verify` and the
/// renderer of diagnostics: now a long name is written whole, unaligned, and a diagnostic on
/// a line too long to quote keeps its message and `file:line:col`.
#[test]
fn names_and_columns_past_65535_characters_are_written_not_panicked_on() {
    let text = std::fs::read_to_string(root().join("models/dc_motor.bg")).expect("model");
    let long = format!("R{}", "e".repeat(70_000));
    let unit = "V".repeat(70_000);
    let element = format!("R{}", "m".repeat(70_000));
    let model = (text.replace(
        "param Re = 0.3 [Ohm]",
        &format!("param {long} = 0.3 [{unit}]"),
    ))
    .replace("R  Rm    = Re", &format!("R  {element} = {long}"))
    .replace("-> Rm, Lm", &format!("-> {element}, Lm"));
    let dir = scratch("long-names");
    let path = dir.join("long.bg");
    std::fs::write(&path, &model).expect("write");
    let file = path.display().to_string();
    for (args, name) in [
        (vec!["check", file.as_str()], &long),
        (vec![file.as_str(), "--emit", "text"], &long),
        (vec!["verify", file.as_str(), "--steps", "200"], &element),
    ] {
        let out = bgc(&args);
        assert_eq!(code(&out), 0, "{args:?}: {}", stderr(&out));
        assert!(
            stdout(&out).contains(name.as_str()),
            "{args:?}: the name is written whole"
        );
    }
    let bad = format!("{}\nSe oops = nowhere\n", text.trim_end())
        .replace("Se oops", &format!("{}Se oops", " ".repeat(70_000)));
    std::fs::write(&path, bad).expect("write");
    let out = bgc(&["check", &file]);
    assert_eq!(code(&out), 1, "{}", stderr(&out));
    assert!(stderr(&out).contains("long.bg:"), "{}", stderr(&out));
    assert!(stderr(&out).len() < 10_000, "the long line is not quoted");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Numeric options that can verify or calibrate nothing are usage errors, said before any
/// work: `--steps 99999999999` once ran for more than ten minutes, `--steps 0`, `--step nan`
/// and scales of `inf` or `1e308` gave false verification failures, and `--margin 1e308`
/// wrote `inf` thresholds with exit 0.
#[test]
fn numeric_options_out_of_their_range_are_usage_errors() {
    for (option, value, said) in [
        ("--steps", "0", "steps must be 1 to"),
        ("--steps", "99999999999", "steps must be 1 to"),
        ("--step", "nan", "step must be a finite number"),
        ("--step=-0.001", "", "step must be a finite number"),
        ("--input-scale", "inf", "input scale must be a number in"),
        ("--state-scale", "1e308", "state scale must be a number in"),
    ] {
        let mut args = vec!["verify", "models/dc_motor.bg", option];
        args.extend([value].into_iter().filter(|v| !v.is_empty()));
        let out = bgc(&args);
        assert_eq!(code(&out), 2, "{option} {value}: {}", stderr(&out));
        assert!(
            stderr(&out).contains(said),
            "{option} {value}: {}",
            stderr(&out)
        );
        assert!(stdout(&out).is_empty(), "{option} {value}: printed a table");
    }
    let dir = scratch("margin");
    let record = dir.join("r.csv").display().to_string();
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "duration 1",
        "-e",
        "step 0.001",
        "-e",
        "input U0 = 1 - cos(3*t)",
        "-e",
        "noise y1 1e-3",
        "-e",
        "noise i 1e-3",
        "-o",
        &record,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let out = bgc(&[
        "residuals",
        "models/dc_motor.bg",
        &record,
        "--calibrate",
        &record,
        "--margin",
        "1e308",
    ]);
    assert_eq!(code(&out), 2, "{}", stderr(&out));
    assert!(stderr(&out).contains("margin 1e308"), "{}", stderr(&out));
    assert!(
        !stdout(&out).contains("inf"),
        "an infinite threshold was written"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Floods of diagnostics are bounded: a group bond of 100 sources into 100 resistors (each
/// of its 200 errors pointing at every bond of the line) printed 14 MB, and 20,000 unused
/// parameters 20,000 warnings. Now at most 50 of each kind in full, 8 places each, then a
/// count of the rest.
#[test]
fn a_flood_of_diagnostics_is_cut_to_what_a_reader_reads() {
    let dir = scratch("flood");
    let names = |prefix: &str| (0..100).map(|k| format!("{prefix}{k}")).collect::<Vec<_>>();
    let (sources, resistors) = (names("s"), names("r"));
    let mut flood = String::from("model flood\ninput U\n");
    for s in &sources {
        flood.push_str(&format!("Se {s} = U\n"));
    }
    for r in &resistors {
        flood.push_str(&format!("R {r} = 1\n"));
    }
    flood.push_str(&format!(
        "{} -> {}\n",
        sources.join(", "),
        resistors.join(", ")
    ));
    let mut unused = String::from("model unused\ninput U\n");
    for k in 0..20_000 {
        unused.push_str(&format!("param p{k} = 1\n"));
    }
    unused.push_str("Se s = U\nR r = 1\ns -> r\n");
    for (name, text, said) in [
        ("flood.bg", flood, "and 150 more errors"),
        ("unused.bg", unused, "and 19950 more warnings"),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("write");
        let out = bgc(&["check", &path.display().to_string()]);
        let report = stderr(&out);
        assert!(
            report.contains(said),
            "{name}: {}",
            &report[report.len().saturating_sub(500)..]
        );
        assert!(
            report.len() < 1_000_000,
            "{name}: {} bytes of diagnostics",
            report.len()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
