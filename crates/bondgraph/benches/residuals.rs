//! The bench's generated `residuals` (its ARRs as written) against the same two ARRs written
//! by hand, and the streaming `ResidualGenerator` from raw samples, for each realisation.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

mod direct {
    bondgraph::bond_graph!("../../models/backlash_bench.bg", realise = direct);
}
mod integrated {
    bondgraph::bond_graph!("../../models/backlash_bench.bg");
}

use direct::backlash_bench as bench;
use integrated::backlash_bench as lowest;

/// The two ARRs as an engineer would write them from the paper's equations: the armature
/// circuit with the motor and load dynamics substituted, and the twist balance through the
/// dead-zone sigmoid.
#[inline(never)]
fn by_hand(p: &bench::Params, s: &bench::Signals) -> [f64; 2] {
    // Load torque seen through the gear, and the motor torque that drives both shafts.
    let load = p.Js * s.y2_d2 + p.fs * s.y2_d1;
    let current = (p.Je * s.y1_d1 + p.fe * s.y1 + (p.Js * s.y2_d1 + p.fs * s.y2) / p.N) / p.ke;
    let current_d1 = (p.Je * s.y1_d2 + p.fe * s.y1_d1 + load / p.N) / p.ke;
    let arr1 = s.U0 - p.Re * current - p.L * current_d1 - p.ke * s.y1;
    let e = (p.gamma * (p.N * s.y2_int - s.y1_int)).exp();
    let slope = 8.0 * p.j0 * p.gamma * e / ((e + 1.0) * (e + 1.0));
    let arr2 = (p.N * s.y2 - s.y1) * (slope - 1.0) - load / (p.N * p.K);
    [arr1, arr2]
}

fn signals(k: usize) -> bench::Signals {
    let x = k as f64 * 1e-3;
    bench::Signals::from_array(std::array::from_fn(|i| (x + i as f64).sin()))
}

fn residuals(c: &mut Criterion) {
    let p = bench::Params::default();
    let points: Vec<bench::Signals> = (0..1024).map(signals).collect();
    // The two must agree before their speeds are compared.
    for s in &points {
        let (a, b) = (bench::residuals(&p, s), by_hand(&p, s));
        for k in 0..2 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-9 * (1.0 + b[k].abs()),
                "{a:?} {b:?}"
            );
        }
    }
    let mut group = c.benchmark_group("bench_residuals");
    group.throughput(Throughput::Elements(points.len() as u64));
    group.bench_function("generated", |b| {
        b.iter(|| {
            for s in &points {
                black_box(bench::residuals(black_box(&p), black_box(s)));
            }
        })
    });
    group.bench_function("by_hand", |b| {
        b.iter(|| {
            for s in &points {
                black_box(by_hand(black_box(&p), black_box(s)));
            }
        })
    });
    group.finish();
}

/// Ten thousand raw samples `[U0, y1, y2]`, `h` seconds apart.
fn raw_samples(h: f64) -> Vec<(f64, [f64; 3])> {
    (0..10_000)
        .map(|k| {
            let t = k as f64 * h;
            (t, [t.sin(), (1.3 * t).cos(), (0.7 * t).sin()])
        })
        .collect()
}

fn generator(c: &mut Criterion) {
    let p = bench::Params::default();
    let h = 1e-3;
    let samples = raw_samples(h);
    let mut group = c.benchmark_group("residual_generator");
    group.throughput(Throughput::Elements(samples.len() as u64));
    for window in [11usize, 31] {
        group.bench_function(format!("direct_savitzky_golay_{window}"), |b| {
            b.iter(|| {
                let mut g = bench::ResidualGenerator::savitzky_golay(p, h, window, 3)
                    .expect("valid estimator");
                for &(t, s) in &samples {
                    black_box(g.push(t, black_box(s)));
                }
            })
        });
        group.bench_function(format!("integrated_savitzky_golay_{window}"), |b| {
            b.iter(|| {
                let params = lowest::Params::default();
                let mut g = lowest::ResidualGenerator::savitzky_golay(params, h, window, 3)
                    .expect("valid estimator");
                for &(t, s) in &samples {
                    black_box(g.push(t, black_box(s)));
                }
            })
        });
        group.bench_function(format!("integrated_modulating_{window}"), |b| {
            b.iter(|| {
                let params = lowest::Params::default();
                let mut g = lowest::ResidualGenerator::modulating(params, h, window)
                    .expect("valid estimator");
                for &(t, s) in &samples {
                    black_box(g.push(t, black_box(s)));
                }
            })
        });
    }
    group.finish();
}

/// The runtime's fault-size estimator on the bench's generated generator: one parameter
/// sized (two copies of the generator and the recursive least squares), per sample.
fn fault_size(c: &mut Criterion) {
    let h = 1e-3;
    let samples = raw_samples(h);
    let template = lowest::ResidualGenerator::savitzky_golay(lowest::Params::default(), h, 31, 3)
        .expect("valid estimator");
    let j0 = (lowest::Params::NAMES.iter().position(|n| *n == "j0")).expect("the dead zone");
    let mut group = c.benchmark_group("fault_size");
    group.throughput(Throughput::Elements(samples.len() as u64));
    group.bench_function("bench_j0_savitzky_golay_31", |b| {
        b.iter(|| {
            let mut size = bondgraph::FaultSize::new(&template, j0, &[4.6e-3, 4.2e-3], 2000)
                .expect("valid settings");
            for &(t, s) in &samples {
                size.push(t, black_box(&s));
            }
            black_box(size.estimate())
        })
    });
    group.finish();
}

criterion_group!(benches, residuals, generator, fault_size);
criterion_main!(benches);
