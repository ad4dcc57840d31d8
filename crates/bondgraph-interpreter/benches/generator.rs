//! The interpreted residual generator of the bench (ARRs integrated once, Savitzky–Golay
//! fits over 11 samples of degree 3) on the waves the runtime's `residual_generator` bench
//! feeds the generated code: the two figures side by side say what interpreting costs.

use std::hint::black_box;

use bondgraph_core::Options;
use bondgraph_interpreter::{Estimator, Fit, Generator};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn generator(c: &mut Criterion) {
    let text = include_str!("../../../models/backlash_bench.bg");
    let out = bondgraph_core::compile(text, "backlash_bench.bg", &Options::default())
        .expect("the bench compiles");
    let model = &out.compiled;
    let program = model.program();
    let names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["U0", "y1", "y2"], "the generated bench's raw order");
    let params: Vec<f64> = model.parameters.values().map(|p| p.value).collect();
    let h = 1e-3;
    let time: Vec<f64> = (0..10_000).map(|k| k as f64 * h).collect();
    let waves: [Vec<f64>; 3] = [
        time.iter().map(|t| t.sin()).collect(),
        time.iter().map(|t| (1.3 * t).cos()).collect(),
        time.iter().map(|t| (0.7 * t).sin()).collect(),
    ];
    let raw: Vec<&[f64]> = waves.iter().map(Vec::as_slice).collect();
    let mut group = c.benchmark_group("residual_generator");
    group.throughput(Throughput::Elements(time.len() as u64));
    for window in [11usize, 31] {
        let fit = Fit {
            step: h,
            estimator: Estimator::SavitzkyGolay { window, degree: 3 },
            integration: Vec::new(),
        };
        group.bench_function(format!("interpreted_savitzky_golay_{window}"), |b| {
            b.iter(|| {
                let mut g = Generator::new(model, &program, &params, &fit).expect("valid");
                g.run(&time, &raw, false, |e| {
                    black_box(e.residual(0));
                });
            })
        });
    }
    group.finish();
}

criterion_group!(benches, generator);
criterion_main!(benches);
