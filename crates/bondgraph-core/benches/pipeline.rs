//! The pipeline on generated chains of N mass-spring-damper stages with a velocity detector on
//! every 5th mass: causality alone, and text to ARRs and FSM, for N = 100, 1,000 and 10,000;
//! then the e-graph's rewriting of every expression for display.
//!
//! In this chain the force between two measured masses is never measured. The balance of each
//! measured mass is therefore torn, and the ARRs are freed of the torn forces by elimination
//! over d/dt (`fdi::eliminate`): each ARR holds the detectors next to it only, so the work per
//! stage is bounded and the pipeline grows linearly.

use std::hint::black_box;

use bondgraph_core::generate::{mass_spring_chain, mass_spring_chain_varied};
use bondgraph_core::{compile, Compiled, Derive, Options};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn run(text: &str, derive: Derive, simplify: bool) -> Compiled {
    let options = Options {
        derive,
        simplify: simplify.then(Default::default),
        ..Options::default()
    };
    match compile(text, "chain.bg", &options) {
        Ok(out) => out.compiled,
        Err(_) => panic!("generated chains are valid"),
    }
}

/// One group: `chain(stages)` compiled to `derive`, with or without the e-graph, at each size.
fn sweep(
    c: &mut Criterion,
    name: &str,
    sizes: &[usize],
    chain: fn(usize, usize) -> String,
    derive: Derive,
    simplify: bool,
) {
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    for &stages in sizes {
        let text = chain(stages, 5);
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &text, |b, text| {
            b.iter(|| {
                let c = run(black_box(text), derive, simplify);
                black_box((c.states.len(), c.arrs.len(), c.components.len()))
            })
        });
    }
    group.finish();
}

/// Text to state equations, canonical forms (what `--emit state --canonical` needs).
fn state_equations(c: &mut Criterion) {
    let sizes = [100, 1_000, 10_000];
    sweep(
        c,
        "state_equations",
        &sizes,
        mass_spring_chain,
        Derive::StateEquations,
        false,
    );
}

/// Text to ARRs and FSM, canonical forms (`--canonical`).
fn full_pipeline(c: &mut Criterion) {
    let sizes = [100, 1_000, 10_000];
    sweep(
        c,
        "pipeline",
        &sizes,
        mass_spring_chain,
        Derive::Everything,
        false,
    );
}

/// The default run: the same, with every expression rewritten by the e-graph (default
/// limits). Each expression gets its own bounded search, so the cost is linear in their
/// number; 10,000 stages are left out to keep the run short.
fn simplify(c: &mut Criterion) {
    let sizes = [10, 100, 1_000];
    sweep(
        c,
        "simplify",
        &sizes,
        mass_spring_chain,
        Derive::Everything,
        true,
    );
}

/// Chains whose every stage has parameters of its own, canonical forms: the ARR of a
/// detector between two stretches of unmeasured masses applies one stretch's operator to an
/// auxiliary signal standing for what the other leaves (`fdi/auxiliary.rs`), so each ARR has
/// the same size however long the chain. Before auxiliary signals, these ARRs were multiplied
/// out and refused as too large from 10 stages on (1.45 s at 10 stages, 5.6 s at 20).
fn per_stage_parameters(c: &mut Criterion) {
    let sizes = [10, 20, 100, 1_000];
    let chain = mass_spring_chain_varied;
    sweep(
        c,
        "per_stage_parameters",
        &sizes,
        chain,
        Derive::Everything,
        false,
    );
}

/// The same, the default run (every expression offered to the e-graph).
fn per_stage_default(c: &mut Criterion) {
    let sizes = [10, 100];
    let chain = mass_spring_chain_varied;
    sweep(
        c,
        "per_stage_default",
        &sizes,
        chain,
        Derive::Everything,
        true,
    );
}

/// The structural fault classes of the chain with its own parameters per stage: parsing,
/// the diagnosis equations and the classes (one dominator tree per round, the rounds as many
/// as the faults near one detector), no ARR derived.
fn classes(c: &mut Criterion) {
    let mut group = c.benchmark_group("classes");
    group.sample_size(10);
    for stages in [100, 1_000, 10_000] {
        let text = mass_spring_chain_varied(stages, 5);
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &text, |b, text| {
            b.iter(|| black_box(bondgraph_core::structural_classes(black_box(text))))
        });
    }
    group.finish();
}

/// The candidate residuals of `chain`: parsing, the whole model's ARRs and FSM, the
/// structural classes, and one derivation of the part around each class (above 32 classes).
fn candidates_of(c: &mut Criterion, name: &str, chain: fn(usize, usize) -> String) {
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    for stages in [100, 1_000, 10_000] {
        let text = chain(stages, 5);
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_with_input(BenchmarkId::from_parameter(stages), &text, |b, text| {
            b.iter(|| black_box(bondgraph_core::candidate_residuals(black_box(text))))
        });
    }
    group.finish();
}

/// The choice of `--residuals best` among `chain`'s candidates, found once beforehand.
fn selection_of(c: &mut Criterion, name: &str, chain: fn(usize, usize) -> String) {
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    for stages in [100, 1_000, 10_000] {
        // Found when the size is measured, not when another one is.
        let set = std::cell::OnceCell::new();
        group.throughput(Throughput::Elements(stages as u64));
        group.bench_function(BenchmarkId::from_parameter(stages), |b| {
            let set = set.get_or_init(|| bondgraph_core::candidate_residuals(&chain(stages, 5)));
            b.iter(|| black_box(set.as_ref().map(|s| s.best())))
        });
    }
    group.finish();
}

/// Candidates on the chain with parameters of its own per stage: parts of 40 nodes.
fn candidates(c: &mut Criterion) {
    candidates_of(c, "candidates", mass_spring_chain_varied);
}

/// Candidates on the chain whose stages share their parameters: parts of up to 100 nodes,
/// which reach every structural class.
fn candidates_shared(c: &mut Criterion) {
    candidates_of(c, "candidates_shared", mass_spring_chain);
}

/// The choice of `best` on the chain with parameters of its own per stage.
fn selection(c: &mut Criterion) {
    selection_of(c, "selection", mass_spring_chain_varied);
}

/// The choice of `best` on the chain whose stages share their parameters.
fn selection_shared(c: &mut Criterion) {
    selection_of(c, "selection_shared", mass_spring_chain);
}

criterion_group!(
    benches,
    classes,
    candidates,
    candidates_shared,
    selection,
    selection_shared,
    state_equations,
    full_pipeline,
    simplify,
    per_stage_parameters,
    per_stage_default
);
criterion_main!(benches);
