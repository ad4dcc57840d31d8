//! Times the candidate residuals and the choice of `--residuals best` on a generated chain:
//! `cargo run --release -p bondgraph-core --example candidates -- STAGES [EVERY] [shared]` (a
//! velocity detector every EVERY-th mass, 5 by default; parameters of its own per stage, or
//! shared along the chain).

use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let number =
        |a: Option<String>, default: usize| a.and_then(|v| v.parse().ok()).unwrap_or(default);
    let stages = number(args.next(), 100);
    let every = number(args.next(), 5).max(1);
    let text = if args.next().as_deref() == Some("shared") {
        bondgraph_core::generate::mass_spring_chain(stages, every)
    } else {
        bondgraph_core::generate::mass_spring_chain_varied(stages, every)
    };
    let start = Instant::now();
    let Some(set) = bondgraph_core::candidate_residuals(&text) else {
        eprintln!("the generated chain did not compile");
        std::process::exit(1);
    };
    let derived = start.elapsed();
    let start = Instant::now();
    let (kept, classes) = set.best();
    let chosen = start.elapsed();
    let structural = bondgraph_core::structural_classes(&text).unwrap_or(0);
    println!(
        "{stages} stages, a detector every {every}: {} candidates in {derived:.2?}; best keeps {kept}, telling {classes} of {structural} structural classes apart, in {chosen:.2?}",
        set.len()
    );
}
