//! Writes a generated mass-spring chain to standard output, to time `bgc` on large models:
//! `cargo run --release -p bondgraph-core --example chain -- 1000 [shared|varied] > chain.bg`.

use bondgraph_core::generate::{mass_spring_chain, mass_spring_chain_varied};

fn main() {
    let mut args = std::env::args().skip(1);
    let stages = args.next().and_then(|s| s.parse::<usize>().ok());
    let Some(stages) = stages.filter(|&n| n > 0) else {
        eprintln!("usage: chain STAGES [shared|varied]  (a velocity detector every 5th mass)");
        std::process::exit(2);
    };
    let text = match args.next().as_deref() {
        None | Some("shared") => mass_spring_chain(stages, 5),
        Some("varied") => mass_spring_chain_varied(stages, 5),
        Some(other) => {
            eprintln!("unknown parameter mode `{other}`: expected `shared` or `varied`");
            std::process::exit(2);
        }
    };
    print!("{text}");
}
