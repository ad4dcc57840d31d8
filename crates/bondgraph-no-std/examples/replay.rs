//! Runs the `no_std` build of the bench's residual generator over a CSV record on the host
//! and prints `t` and every residual per estimated instant, as `bgc residuals` names them.
//!
//! `cargo run -p bondgraph-no-std --example replay -- RECORD.csv STEP WINDOW`

use bondgraph_no_std::backlash_bench::{RAW_SIGNALS, RESIDUALS};
use bondgraph_no_std::{Monitor, RAW};

fn main() {
    if let Err(why) = run() {
        eprintln!("replay: {why}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [record, step, window] = args.as_slice() else {
        return Err("usage: replay RECORD.csv STEP WINDOW".into());
    };
    let step: f64 = step.parse().map_err(|e| format!("step `{step}`: {e}"))?;
    let window: usize = window
        .parse()
        .map_err(|e| format!("window `{window}`: {e}"))?;
    let text = std::fs::read_to_string(record).map_err(|e| format!("{record}: {e}"))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("an empty record")?.split(',').collect();
    let column = |name: &str| {
        (header.iter().position(|h| *h == name)).ok_or(format!("{record}: no column `{name}`"))
    };
    let time = column("t")?;
    let raw: Vec<usize> = RAW_SIGNALS
        .iter()
        .map(|s| column(s))
        .collect::<Result<_, _>>()?;
    let mut monitor = Monitor::new(step, window).map_err(|e| e.to_string())?;
    println!("t,{}", RESIDUALS.join(","));
    for (row, line) in lines.enumerate() {
        let cells: Vec<f64> = (line.split(','))
            .map(|c| c.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{record}: row {}: {e}", row + 2))?;
        let sample: [f64; RAW] = std::array::from_fn(|i| cells[raw[i]]);
        if let Some((at, residuals)) = monitor.push(cells[time], sample) {
            let cells: Vec<String> = residuals.iter().map(|r| r.to_string()).collect();
            println!("{at},{}", cells.join(","));
        }
    }
    Ok(())
}
