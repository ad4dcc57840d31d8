//! Writes a generated mass-spring chain to standard output, to time `bgc` on large models:
//! `cargo run --release -p bondgraph-core --example chain -- 1000 [shared|varied] [EVERY] >
//! chain.bg`, with a velocity detector every EVERY-th mass (5 by default).

use bondgraph_core::generate::{mass_spring_chain, mass_spring_chain_varied};

fn main() {
    let mut args = std::env::args().skip(1);
    let stages = args.next().and_then(|s| s.parse::<usize>().ok());
    let Some(stages) = stages.filter(|&n| n > 0) else {
        eprintln!("usage: chain STAGES [shared|varied] [EVERY]  (a velocity detector every EVERY-th mass, 5 by default)");
        std::process::exit(2);
    };
    let mode = args.next();
    let every = args
        .next()
        .and_then(|s| s.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(5);
    let text = match mode.as_deref() {
        None | Some("shared") => mass_spring_chain(stages, every),
        Some("varied") => mass_spring_chain_varied(stages, every),
        Some(other) => {
            eprintln!("unknown parameter mode `{other}`: expected `shared` or `varied`");
            std::process::exit(2);
        }
    };
    print!("{text}");
}
