//! Writes a CSV of the bench's simulated samples for the `bench_csv` example: the armature
//! voltage and both speeds every 5 ms for 8 s, with the armature resistance 50 % higher from
//! 4 s on (a fault appearing mid-record). The core's simulation does the work; `bgc simulate`
//! with the same scenario writes the same samples, with the states as well.
//!
//! `cargo run -p bondgraph --example simulate_bench > bench.csv`

use bondgraph_core::{compile, Options};
use bondgraph_sim::{parse_scenario, Simulation};

/// Tight enough that the record is exact to far below the residuals.
const SCENARIO: &str = "duration 8\nstep 0.005\ntolerance 1e-12\n\
                        input U0 = 2*sin(0.8*t) + 0.5*sin(2.3*t)\n\
                        fault Re = 1.5*Re at 4\n";

fn main() {
    if let Err(e) = run() {
        eprintln!("{e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let text = include_str!("../../../models/backlash_bench.bg");
    let c = compile(text, "backlash_bench.bg", &Options::default())
        .map_err(|d| format!("the bench does not compile: {d:?}"))?
        .compiled;
    let (scenario, d) = parse_scenario(SCENARIO);
    let scenario = scenario.ok_or_else(|| format!("the scenario is wrong: {d:?}"))?;
    let simulation =
        Simulation::new(&c, &scenario).map_err(|d| format!("cannot simulate: {d:?}"))?;
    let record = simulation.run(|_| {}).map_err(|e| e.to_string())?;
    let columns: Vec<&Vec<f64>> = ["t", "U0", "y1", "y2"]
        .iter()
        .map(|name| {
            record
                .columns
                .iter()
                .position(|c| c == name)
                .map(|k| &record.values[k])
                .ok_or_else(|| format!("no column {name}"))
        })
        .collect::<Result<_, _>>()?;
    println!("t,U0,y1,y2");
    for k in 0..columns[0].len() {
        let row: Vec<String> = columns.iter().map(|c| c[k].to_string()).collect();
        println!("{}", row.join(","));
    }
    Ok(())
}
