//! The pipeline on generated chains of N mass-spring-damper stages with a velocity detector on
//! every 5th mass: causality alone, and text to ARRs and FSM, for N = 100, 1,000 and 10,000;
//! then the e-graph's rewriting of every expression for display.
//!
//! In this chain the force between two measured masses is never measured. The balance of each
//! measured mass is therefore torn, and the ARRs are freed of the torn forces by elimination
//! over d/dt (`fdi::eliminate`): each ARR holds the detectors next to it only, so the work per
//! stage is bounded and the pipeline grows linearly.

use std::hint::black_box;

use bondgraph_core::analysis::analyse;
use bondgraph_core::causality::{assign, Mode};
use bondgraph_core::generate::mass_spring_chain;
use bondgraph_core::symbolic::rewrite::Limits;
use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};

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

/// How expressions are written (egg, default limits): every state equation, output and ARR of
/// the chain. Each expression gets its own bounded search, so the cost is linear in their
/// number; 10,000 stages are left out to keep the run short (about 100 times 100 stages).
fn simplify(c: &mut Criterion) {
    let mut group = c.benchmark_group("simplify");
    group.sample_size(10);
    for stages in [10usize, 100, 1_000] {
        let text = mass_spring_chain(stages, 5);
        let (model, _) = bondgraph_core::load(&text);
        let model = model.expect("generated chains are valid");
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &model, |b, model| {
            b.iter_batched(
                || analyse(model),
                |mut analysis| black_box(analysis.simplify(Limits::default()).len()),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, causality, full_pipeline, simplify);
criterion_main!(benches);
