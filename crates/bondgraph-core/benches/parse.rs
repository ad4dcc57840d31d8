//! Parsing and validating generated chains of mass-spring-damper stages, up to 100,000
//! elements: the front end's cost must grow about linearly with model size.

use std::hint::black_box;

use bondgraph_core::generate::mass_spring_chain;
use bondgraph_core::{compile, Derive, Options};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn parse_and_validate(c: &mut Criterion) {
    let mut group = c.benchmark_group("load");
    group.sample_size(10);
    // Three elements per stage plus the driving source: 33,333 stages make 100,000 elements.
    for stages in [333usize, 3_333, 33_333] {
        let text = mass_spring_chain(stages, 5);
        let elements = 3 * stages + 1;
        let options = Options {
            derive: Derive::Nothing,
            simplify: None,
            ..Options::default()
        };
        assert!(compile(&text, "chain.bg", &options).is_ok());
        group.throughput(Throughput::Elements(elements as u64));
        group.bench_with_input(BenchmarkId::from_parameter(elements), &text, |b, text| {
            b.iter(|| compile(black_box(text), "chain.bg", &options).is_ok())
        });
    }
    group.finish();
}

criterion_group!(benches, parse_and_validate);
criterion_main!(benches);
