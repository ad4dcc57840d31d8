//! The pipeline on generated chains of N mass-spring-damper stages with a velocity detector on
//! every 5th mass: causality alone, and text to ARRs and FSM, for N = 100, 1,000 and 10,000.
//!
//! In this chain the force between two measured masses is never measured. The balance of each
//! measured mass is therefore torn, and the ARRs are freed of the torn forces by elimination
//! over d/dt (`fdi::eliminate`): each ARR holds the detectors next to it only, so the work per
//! stage is bounded and the pipeline grows linearly.

use std::hint::black_box;

use bondgraph_core::analysis::analyse;
use bondgraph_core::causality::{assign, Mode};
use bondgraph_core::generate::mass_spring_chain;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn causality(c: &mut Criterion) {
    let mut group = c.benchmark_group("causality");
    group.sample_size(10);
    for stages in [100usize, 1_000, 10_000] {
        let text = mass_spring_chain(stages, 5);
        let (model, _) = bondgraph_core::load(&text);
        let model = model.expect("generated chains are valid");
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &model, |b, model| {
            b.iter(|| black_box(assign(model, Mode::Diagnosis).redundant().len()))
        });
    }
    group.finish();
}

fn full_pipeline(c: &mut Criterion) {
    let mut group = c.benchmark_group("pipeline");
    group.sample_size(10);
    for stages in [100usize, 1_000, 10_000] {
        let text = mass_spring_chain(stages, 5);
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &text, |b, text| {
            b.iter(|| {
                let (model, _) = bondgraph_core::load(black_box(text));
                let model = model.expect("generated chains are valid");
                let analysis = analyse(&model);
                assert_eq!(analysis.diagnosis.arrs.len(), stages.div_ceil(5));
                black_box(analysis.fsm.rows.len())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, causality, full_pipeline);
criterion_main!(benches);
