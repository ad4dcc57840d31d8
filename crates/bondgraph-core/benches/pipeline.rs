//! The pipeline on generated chains of N mass-spring-damper stages with a velocity detector on
//! every 5th mass: causality alone, and text to ARRs and FSM.
//!
//! In this chain the force between two measured masses is never measured, so under derivative
//! causality each segment between detectors passes the unmeasured force on to the next by
//! differentiation: the k-th ARR carries derivatives of order about 2·5·k of the first
//! detector, and the expressions grow with k. Both stages are therefore measured on small
//! chains (the closing notes of issue [2/4] give the figures and what it would take to reach
//! 10,000 stages).

use std::hint::black_box;

use bondgraph_core::analysis::analyse;
use bondgraph_core::causality::{assign, Mode};
use bondgraph_core::generate::mass_spring_chain;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn causality(c: &mut Criterion) {
    let mut group = c.benchmark_group("causality");
    group.sample_size(10);
    for stages in [25usize, 50, 100, 200] {
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
    for stages in [10usize, 20, 40] {
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
