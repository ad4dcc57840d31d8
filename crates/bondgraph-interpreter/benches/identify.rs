//! Identification of the DC motor (`models/dc_motor.bg`) from a 30-s record of a plant whose
//! resistance, inertia and friction are 10–20 % off the model's (integrated here by RK4 at
//! a tenth of the step, no noise): the whole fit, from the model's values to the intervals
//! and the undetermined combinations, in samples per second of record. And the size of a
//! fault late in a long record (its resistance × 1.5 after 110 s of 120), fitted over the
//! 5 s after it: what a size costs against the record's length.

use std::hint::black_box;

use bondgraph_core::{Compiled, Options};
use bondgraph_interpreter::{identify, Estimator, Fit, Integration, Record, Settings, Sizing};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// The motor's current and speed under `U0 = 6 + 12 sin 0.5t + 3 sin 7t`, sampled every `h`,
/// its resistance `fault` times its value from `at` seconds on.
fn record(seconds: f64, h: f64, (fault, at): (f64, f64)) -> (Vec<f64>, [Vec<f64>; 3]) {
    let (re, l, ke, je, fe) = (0.36, 0.5, 0.5, 0.88, 0.12);
    let u = |t: f64| 6.0 + 12.0 * (0.5 * t).sin() + 3.0 * (7.0 * t).sin();
    let rates = |t: f64, x: [f64; 2]| {
        let re = if t >= at { re * fault } else { re };
        [
            (u(t) - re * x[0] - ke * x[1]) / l,
            (ke * x[0] - fe * x[1]) / je,
        ]
    };
    let n = (seconds / h) as usize;
    let (mut time, mut input, mut current, mut speed) = (vec![], vec![], vec![], vec![]);
    let mut x = [0.0, 0.0];
    let dt = h / 10.0;
    for k in 0..n {
        let t0 = k as f64 * h;
        time.push(t0);
        input.push(u(t0));
        current.push(x[0]);
        speed.push(x[1]);
        for j in 0..10 {
            let t = t0 + j as f64 * dt;
            let add = |x: [f64; 2], d: [f64; 2], s: f64| [x[0] + s * d[0], x[1] + s * d[1]];
            let k1 = rates(t, x);
            let k2 = rates(t + dt / 2.0, add(x, k1, dt / 2.0));
            let k3 = rates(t + dt / 2.0, add(x, k2, dt / 2.0));
            let k4 = rates(t + dt, add(x, k3, dt));
            x = [
                x[0] + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
                x[1] + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            ];
        }
    }
    (time, [input, current, speed])
}

/// The DC motor, compiled.
fn motor() -> Compiled {
    let text = include_str!("../../../models/dc_motor.bg");
    (bondgraph_core::compile(text, "dc_motor.bg", &Options::default()))
        .expect("the motor compiles")
        .compiled
}

fn identification(c: &mut Criterion) {
    let model = &motor();
    let program = model.program();
    let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["U0", "i", "y1"], "the motor's raw order");
    let start: Vec<f64> = model.parameters.values().map(|p| p.value).collect();
    let h = 1e-3;
    let (time, columns) = record(30.0, h, (1.0, f64::INFINITY));
    let settings = Settings {
        fit: Fit {
            step: h,
            estimator: Estimator::SavitzkyGolay {
                window: 51,
                degree: 3,
            },
            integration: vec![Integration::default(); model.arrs.len()],
        },
        free: Vec::new(),
        bounded: false,
        span: None,
    };
    let mut group = c.benchmark_group("identify");
    group.sample_size(10);
    group.throughput(Throughput::Elements(time.len() as u64));
    group.bench_function("dc_motor_30s", |b| {
        b.iter(|| {
            let records = [Record {
                time: &time,
                raw: columns.iter().map(Vec::as_slice).collect(),
                state: None,
            }];
            let found = identify(model, &program, &start, &records, &settings).expect("fits");
            black_box(found.values)
        })
    });
    group.finish();
}

fn sizing(c: &mut Criterion) {
    let model = &motor();
    let program = model.program();
    let params: Vec<f64> = model.parameters.values().map(|p| p.value).collect();
    let h = 1e-3;
    let (time, columns) = record(120.0, h, (1.5, 110.0));
    let ranked = ["Rm".to_string()];
    let mut group = c.benchmark_group("size");
    group.sample_size(10);
    group.throughput(Throughput::Elements(time.len() as u64));
    group.bench_function("dc_motor_120s_fault_at_110s", |b| {
        b.iter(|| {
            let raw = columns.iter().map(Vec::as_slice).collect();
            let sizing = Sizing::new(model, &program, &params, &time, raw, h);
            let sized = sizing.candidates(&ranked, 110.0, 5.0);
            assert!(!sized.is_empty(), "Rm is sized");
            black_box(sized.len())
        })
    });
    group.finish();
}

criterion_group!(benches, identification, sizing);
criterion_main!(benches);
