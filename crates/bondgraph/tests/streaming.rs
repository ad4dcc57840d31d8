//! The bench's residual generator on simulated data: healthy, its residuals stay below a
//! bound derived from the estimator and the sampling step; with a fault in the simulated
//! plant (the armature resistance +50 %, or the dead zone ×3), the residuals the FSM marks
//! rise at least ten times above it, and the candidates include the faulty component.
//!
//! The bound. A centred Savitzky–Golay fit of degree d over w samples is exact on
//! polynomials of degree d, so on a noise-free signal the error of its k-th derivative is
//! at most `M_{d+1} Σ_j |c_kj| |t_j − t|^{d+1} / (d+1)!`
//! ([`bondgraph::SavitzkyGolay::error_bound`]), with `M_{d+1}` the largest |y^(d+1)| (taken
//! from the samples' (d+1)-th differences, with a margin). An integral adds the trapezoid's
//! `T h² max|y''| / 12`. The residual's error is then at most `Σ_i |∂r/∂s_i| E_i` over its
//! fields `s_i`, the partial derivatives taken at each sample (finite differences of the
//! generated `residuals`): the bound is the largest over the record. The plant is integrated
//! by the core's adaptive solver at a relative tolerance of 1e-12, far below.
//!
//! That bound is for the ARRs as written (`realise = direct`). The bench's ARRs realised by
//! integration (the default) are checked against them: on a faulty record, each integrated
//! residual is the integral of the direct one.

use std::collections::HashMap;

use bondgraph::SavitzkyGolay;
use bondgraph_core::{compile, Compiled, Options, Realise};
use bondgraph_sim::{parse_scenario, Simulation};

mod direct {
    bondgraph::bond_graph!("../../models/backlash_bench.bg", realise = direct);
}

mod integrated {
    bondgraph::bond_graph!("../../models/backlash_bench.bg");
}

use direct::backlash_bench as bench;
use integrated::backlash_bench as lowest;

const STEP: f64 = 1e-3;
const SECONDS: f64 = 8.0;
const WINDOW: usize = 31;
const DEGREE: u32 = 3;

fn product() -> Compiled {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../models/backlash_bench.bg"
    );
    let text = std::fs::read_to_string(path).expect("the bench");
    let options = Options {
        realise: Realise::Direct,
        ..Options::default()
    };
    compile(&text, "backlash_bench.bg", &options)
        .expect("valid")
        .compiled
}

/// The armature voltage: a step-free, slowly varying drive that turns the shafts both ways.
fn voltage(t: f64) -> f64 {
    2.0 * (0.8 * t).sin() + 0.5 * (2.3 * t).sin()
}

/// Samples `[U0, y1, y2]` of the plant with the parameters `scale`d by name, every STEP, by
/// the core's simulation at a tight tolerance.
fn simulate(c: &Compiled, scale: &HashMap<&str, f64>) -> Vec<(f64, [f64; 3])> {
    // The drive of `voltage`, as a scenario input.
    let mut scenario = format!(
        "duration {SECONDS}\nstep {STEP}\ntolerance 1e-12\n\
         input U0 = 2*sin(0.8*t) + 0.5*sin(2.3*t)\n"
    );
    for (name, factor) in scale {
        scenario.push_str(&format!("fault {name} = {factor}*{name} at 0\n"));
    }
    let (scenario, d) = parse_scenario(&scenario);
    let scenario = scenario.unwrap_or_else(|| panic!("{d:?}"));
    let record = Simulation::new(c, &scenario)
        .expect("the bench simulates")
        .run(|_| {})
        .expect("runs");
    let column = |name: &str| {
        let k = record.columns.iter().position(|c| c == name).expect(name);
        &record.values[k]
    };
    let (t, y1, y2) = (column("t"), column("y1"), column("y2"));
    let u = column("U0");
    for (&t, &u) in t.iter().zip(u) {
        assert!(
            (u - voltage(t)).abs() < 1e-12,
            "the scenario's input is `voltage`"
        );
    }
    (0..t.len()).map(|k| (t[k], [u[k], y1[k], y2[k]])).collect()
}

/// The largest |y^(m)| of a sampled signal, from its m-th differences, with a 20 % margin.
fn largest_derivative(samples: &[f64], m: u32) -> f64 {
    let mut d = samples.to_vec();
    for _ in 0..m {
        d = d.windows(2).map(|w| (w[1] - w[0]) / STEP).collect();
    }
    1.2 * d.iter().fold(0.0f64, |a, v| a.max(v.abs()))
}

/// Each residual's worst |value| over the record once the window is full, and the bound
/// on each (see the module's doc).
fn run(samples: &[(f64, [f64; 3])]) -> ([f64; 2], [f64; 2]) {
    assert_eq!(bench::RAW_SIGNALS, ["U0", "y1", "y2"]);
    let p = bench::Params::default();
    let mut g = bench::ResidualGenerator::savitzky_golay(p, STEP, WINDOW, DEGREE).expect("valid");
    // The error bound of each field of Signals.
    let probe = SavitzkyGolay::new(2, DEGREE, WINDOW, STEP, true).expect("valid");
    let column = |i: usize| -> Vec<f64> { samples.iter().map(|(_, s)| s[i]).collect() };
    let raw: Vec<Vec<f64>> = (0..3).map(column).collect();
    let next: Vec<f64> = raw
        .iter()
        .map(|y| largest_derivative(y, DEGREE + 1))
        .collect();
    let within: Vec<f64> = raw.iter().map(|y| largest_derivative(y, DEGREE)).collect();
    let curvature: Vec<f64> = raw.iter().map(|y| largest_derivative(y, 2)).collect();
    let error: Vec<f64> = bench::Signals::NAMES
        .iter()
        .map(|name| {
            let (signal, what) = name.split_once('_').unwrap_or((name, ""));
            let i = bench::RAW_SIGNALS
                .iter()
                .position(|s| *s == signal)
                .expect("raw");
            match what {
                "" => probe.error_bound(0, next[i]),
                "d1" => probe.error_bound(1, next[i]),
                "d2" => probe.error_bound(2, next[i]),
                // The trapezoid, then the fit of the integral (whose (d+1)-th derivative
                // is the signal's d-th).
                "int" => {
                    SECONDS * STEP * STEP * curvature[i] / 12.0 + probe.error_bound(0, within[i])
                }
                other => panic!("no bound for {other}"),
            }
        })
        .collect();
    let (mut worst, mut bound) = ([0.0f64; 2], [0.0f64; 2]);
    for &(t, s) in samples {
        let Some(r) = g.push(t, s) else { continue };
        // Only once the integrals have settled past the window's start.
        if t < 1.0 {
            continue;
        }
        for k in 0..2 {
            worst[k] = worst[k].max(r[k].abs());
        }
    }
    // Sensitivities at the healthy trajectory, estimated exactly enough by the raw signals
    // (the partial derivatives vary slowly): largest Σ |∂r/∂s_i| E_i over the record.
    let mut fields = bench::Signals::default();
    let mut integ = [bondgraph::Trapezoid::new(), bondgraph::Trapezoid::new()];
    let mut prev: Option<[f64; 3]> = None;
    let mut prev2: Option<[f64; 3]> = None;
    for &(t, s) in samples {
        let ints = [integ[0].push(t, s[1]), integ[1].push(t, s[2])];
        if let (Some(a), Some(b)) = (prev, prev2) {
            // Central differences at the previous sample, from its neighbours.
            let d1 = |i: usize| (s[i] - b[i]) / (2.0 * STEP);
            let d2 = |i: usize| (s[i] - 2.0 * a[i] + b[i]) / (STEP * STEP);
            fields.U0 = a[0];
            fields.y1 = a[1];
            fields.y1_d1 = d1(1);
            fields.y1_d2 = d2(1);
            fields.y1_int = ints[0];
            fields.y2 = a[2];
            fields.y2_d1 = d1(2);
            fields.y2_d2 = d2(2);
            fields.y2_int = ints[1];
            if t >= 1.0 {
                let slope = sensitivities(&p, &fields);
                for k in 0..2 {
                    let b: f64 = slope[k].iter().zip(&error).map(|(d, e)| d.abs() * e).sum();
                    bound[k] = bound[k].max(b);
                }
            }
        }
        prev2 = prev;
        prev = Some(s);
    }
    (worst, bound)
}

/// The FSM row of `component`.
fn row(fsm: &'static bondgraph::Fsm, component: &str) -> &'static bondgraph::Component {
    fsm.components
        .iter()
        .find(|r| r.name == component)
        .expect("an FSM row")
}

/// ∂r_k/∂s_i for every field, by central differences of the generated residuals.
fn sensitivities(p: &bench::Params, s: &bench::Signals) -> [Vec<f64>; 2] {
    let base = s.to_array();
    let mut out = [Vec::new(), Vec::new()];
    for i in 0..base.len() {
        let h = 1e-6 * (1.0 + base[i].abs());
        let (mut up, mut down) = (base, base);
        up[i] += h;
        down[i] -= h;
        let (ru, rd) = (
            bench::residuals(p, &bench::Signals::from_array(up)),
            bench::residuals(p, &bench::Signals::from_array(down)),
        );
        for k in 0..2 {
            out[k].push((ru[k] - rd[k]) / (2.0 * h));
        }
    }
    out
}

#[test]
fn streaming_residuals_stay_below_their_bound_and_faults_rise_ten_times_above_it() {
    let c = product();
    let healthy = simulate(&c, &HashMap::new());
    let (worst, bound) = run(&healthy);
    eprintln!("healthy: worst {worst:?}, bound {bound:?}");
    for k in 0..2 {
        assert!(
            worst[k] <= bound[k],
            "healthy {}: {:e} above its bound {:e}",
            bench::RESIDUALS[k],
            worst[k],
            bound[k]
        );
    }
    for (parameter, factor, component) in [("Re", 1.5, "Rm"), ("j0", 3.0, "w")] {
        let faulty = simulate(&c, &HashMap::from([(parameter, factor)]));
        let (seen, _) = run(&faulty);
        eprintln!("{parameter} x{factor}: worst {seen:?}");
        let alarms = [seen[0] > bound[0], seen[1] > bound[1]];
        let row = row(&bench::FSM, component);
        for k in 0..2 {
            if row.signature.contains(k) {
                assert!(
                    seen[k] >= 10.0 * bound[k],
                    "{parameter} x{factor}: {} reaches {:e}, under 10x its bound {:e}",
                    bench::RESIDUALS[k],
                    seen[k],
                    bound[k]
                );
            }
        }
        let candidates = bench::candidates(&alarms);
        assert!(
            candidates.contains(&component),
            "{parameter} x{factor}: alarms {alarms:?}, candidates {candidates:?}"
        );
    }
    // The bound is not vacuous: it is small against the residuals' own terms.
    assert!(bound[0] < 1e-3 && bound[1] < 1e-3, "{bound:?}");
}

/// A bank of separate estimators, one per signal, computes what the shared fit computes,
/// and a bank that cannot give the second derivatives the ARRs read is refused.
#[test]
fn any_estimator_bank_gives_the_same_residuals() {
    let c = product();
    let samples = simulate(&c, &HashMap::new());
    let p = bench::Params::default();
    let mut shared =
        bench::ResidualGenerator::savitzky_golay(p, STEP, WINDOW, DEGREE).expect("valid");
    let mut each = bench::ResidualGenerator::with_estimators(p, |order| {
        SavitzkyGolay::new(order, DEGREE, WINDOW, STEP, true)
    })
    .expect("valid");
    assert_eq!(shared.delay(), each.delay());
    let mut compared = 0;
    for &(t, s) in &samples {
        let (a, b) = (shared.push(t, s), each.push(t, s));
        assert_eq!(a.is_some(), b.is_some(), "at {t}");
        if let (Some(a), Some(b)) = (a, b) {
            for k in 0..2 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-9 * a[k].abs().max(1.0),
                    "{t}: {a:?} {b:?}"
                );
            }
            compared += 1;
        }
    }
    assert_eq!(compared, samples.len() - (WINDOW - 1));
    let first_order =
        bondgraph::SavitzkyGolayBank::<{ bench::CHANNELS }, { bench::DIFFERENTIATED }>::new(
            1, DEGREE, WINDOW, STEP, true,
        )
        .expect("valid");
    assert_eq!(
        bench::ResidualGenerator::with_bank(p, first_order).err(),
        Some(bondgraph::EstimatorError::Order {
            order: 1,
            needed: 2
        })
    );
}

/// The bench realised by integration reads no second derivative, and each of its residuals
/// (integrated from the start) is the integral of the ARR as written: on records where a
/// fault moves them far from zero, the trapezoidal integral of the direct residual follows
/// the integrated one. Healthy, the integrated residuals stay a hundred times below what
/// each fault makes of those it marks.
#[test]
fn integrated_residuals_are_the_integrals_of_the_direct_ones() {
    assert!(
        lowest::RAW_ORDERS.iter().all(|&n| n <= 1),
        "{:?}",
        lowest::RAW_ORDERS
    );
    assert!(lowest::Signals::NAMES.iter().all(|n| !n.ends_with("_d2")));
    assert_eq!(lowest::INTEGRATED, [true, true]);
    let c = product();
    let worst = |samples: &[(f64, [f64; 3])]| {
        let mut g = lowest::ResidualGenerator::savitzky_golay(
            lowest::Params::default(),
            STEP,
            WINDOW,
            DEGREE,
        )
        .expect("valid")
        .integrated_from_start();
        let mut d = bench::ResidualGenerator::savitzky_golay(
            bench::Params::default(),
            STEP,
            WINDOW,
            DEGREE,
        )
        .expect("valid");
        let (mut worst, mut apart) = ([0.0f64; 2], [0.0f64; 2]);
        let mut integral = [bondgraph::Trapezoid::new(), bondgraph::Trapezoid::new()];
        let at = g.delay();
        for &(t, s) in samples {
            let (Some(r), Some(direct)) = (g.push(t, s), d.push(t, s)) else {
                continue;
            };
            for k in 0..2 {
                worst[k] = worst[k].max(r[k].abs());
                apart[k] = apart[k].max((r[k] - integral[k].push(t - at, direct[k])).abs());
            }
        }
        (worst, apart)
    };
    let (healthy, _) = worst(&simulate(&c, &HashMap::new()));
    eprintln!("integrated, healthy: worst {healthy:?}");
    for (parameter, factor, component) in [("Re", 1.5, "Rm"), ("j0", 3.0, "w")] {
        let (seen, apart) = worst(&simulate(&c, &HashMap::from([(parameter, factor)])));
        eprintln!("integrated, {parameter} x{factor}: worst {seen:?}, from the direct ones' integral {apart:?}");
        let row = row(&lowest::FSM, component);
        for k in 0..2 {
            if row.signature.contains(k) {
                assert!(
                    seen[k] >= 100.0 * healthy[k],
                    "{parameter} x{factor}: {} reaches {:e}, under 100x its healthy {:e}",
                    lowest::RESIDUALS[k],
                    seen[k],
                    healthy[k]
                );
                assert!(
                    apart[k] <= 0.01 * seen[k],
                    "{parameter} x{factor}: {} is {:e} from the direct residual's integral, against {:e}",
                    lowest::RESIDUALS[k],
                    apart[k],
                    seen[k]
                );
            }
        }
        let alarms = [seen[0] > 10.0 * healthy[0], seen[1] > 10.0 * healthy[1]];
        let candidates = lowest::candidates(&alarms);
        assert!(
            candidates.contains(&component),
            "{parameter} x{factor}: alarms {alarms:?}, candidates {candidates:?}"
        );
    }
}
