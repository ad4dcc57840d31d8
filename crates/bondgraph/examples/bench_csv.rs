//! The bench's residuals on recorded samples: `bond_graph!` compiles the model, a CSV of
//! `t,U0,y1,y2` feeds the streaming generator, and thresholds with debounce raise alarms
//! that the fault signature matrix turns into candidate components.
//!
//! ```text
//! cargo run -p bondgraph --example simulate_bench > bench.csv
//! cargo run -p bondgraph --example bench_csv -- bench.csv
//! ```

use bondgraph::Threshold;

bondgraph::bond_graph!("../../models/backlash_bench.bg");

use backlash_bench as bench;

/// Thresholds on |residual|: the ARRs realised by integration, each residual is its relation's
/// integral over the last 250 samples (V·s for ARR1, rad for ARR2); a few times what the
/// estimators' error gives on this record's healthy part at a 5 ms step.
const LEVELS: [f64; 2] = [0.02, 0.02];

/// Consecutive samples needed to raise or clear an alarm (25 ms at 5 ms).
const DEBOUNCE: u32 = 5;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: bench_csv FILE.csv   (columns t,U0,y1,y2; see simulate_bench)");
        std::process::exit(2);
    };
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(2);
        }
    };
    let rows: Vec<(f64, [f64; 3])> = match parse(&text) {
        Ok(rows) => rows,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(2);
        }
    };
    let step = match rows.as_slice() {
        [a, b, ..] => b.0 - a.0,
        _ => {
            eprintln!("{path}: fewer than two samples");
            std::process::exit(2);
        }
    };
    let mut generator =
        match bench::ResidualGenerator::savitzky_golay(bench::Params::default(), step, 11, 3) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("estimator: {e}");
                std::process::exit(2);
            }
        };
    let mut thresholds = LEVELS.map(|level| Threshold::new(level, DEBOUNCE));
    let mut last_alarms = [false; 2];
    println!("residuals lag the samples by {:.3} s", generator.delay());
    println!(
        "{:>8}  {:>12}  {:>12}",
        "t",
        bench::RESIDUALS[0],
        bench::RESIDUALS[1]
    );
    for (k, &(t, raw)) in rows.iter().enumerate() {
        let Some(r) = generator.push(t, raw) else {
            continue;
        };
        let at = t - generator.delay();
        let alarms = [thresholds[0].update(r[0]), thresholds[1].update(r[1])];
        if k % 100 == 0 {
            println!("{at:>8.3}  {:>12.3e}  {:>12.3e}", r[0], r[1]);
        }
        if alarms != last_alarms {
            println!(
                "{at:>8.3}  alarms {alarms:?}: candidates {:?}",
                bench::candidates(&alarms)
            );
            last_alarms = alarms;
        }
    }
}

/// Rows of `t,U0,y1,y2` after a header line.
fn parse(text: &str) -> Result<Vec<(f64, [f64; 3])>, String> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate().skip(1) {
        let values: Result<Vec<f64>, _> =
            line.split(',').map(|v| v.trim().parse::<f64>()).collect();
        match values.as_deref() {
            Ok([t, u, y1, y2]) => out.push((*t, [*u, *y1, *y2])),
            _ => return Err(format!("line {}: expected four numbers t,U0,y1,y2", n + 1)),
        }
    }
    Ok(out)
}
