//! Random mutations of the other inputs a user writes: scenarios (through the library: parse,
//! build the plant, run it) and recorded CSV (through `bgc residuals`). None may crash, hang
//! or write a NaN with success; every rejection of a scenario is located in its text, every
//! rejection of a record is a `bgc::` diagnostic with exit 1 or 2.
//!
//! The suite runs a small sample (`BGC_FUZZ`, default 40 scenario mutants per scenario file
//! and 30 record mutants); the campaign runs the same code with more, e.g.
//! `BGC_FUZZ=3000 cargo test --release -p bgc --test suite fuzz:: -- --nocapture`, and prints how
//! many inputs it ran and how many were rejected.

use crate::common::mutate::{mutate, Rng};
use crate::common::{bgc, code, root, scratch, stderr, stdout};
use bondgraph_core::{compile, Compiled, Options};
use bondgraph_sim::{parse_scenario, Simulation};

/// How many mutants of each input (`BGC_FUZZ`, default 40).
fn mutants() -> usize {
    std::env::var("BGC_FUZZ")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(40)
}

/// The longest simulated stretch a mutant may ask for, in samples: a mutated `duration`
/// is legal but its run would only cost time.
const MOST_SAMPLES: f64 = 2_000.0;

fn bench() -> Compiled {
    let text = std::fs::read_to_string(root().join("models/backlash_bench.bg")).expect("model");
    compile(&text, "backlash_bench.bg", &Options::default())
        .expect("valid")
        .compiled
}

#[test]
fn mutated_scenarios_never_crash_and_every_rejection_is_located() {
    let c = bench();
    let mut rng = Rng(0x5ce_4a41);
    let (mut total, mut rejected, mut ran) = (0, 0, 0);
    let mut paths: Vec<_> = std::fs::read_dir(root().join("scenarios"))
        .expect("scenarios/")
        .map(|e| e.expect("entry").path())
        .collect();
    paths.sort();
    for path in paths {
        let original = std::fs::read(&path).expect("scenario");
        for _ in 0..mutants() {
            let (bytes, what) = mutate(&original, &mut rng);
            let Ok(text) = String::from_utf8(bytes) else {
                continue;
            };
            total += 1;
            let context = || format!("{} ({what}):\n{text}", path.display());
            let (scenario, diagnostics) = parse_scenario(&text);
            for d in diagnostics.iter() {
                assert!(
                    d.span.end <= text.len() && text.is_char_boundary(d.span.start),
                    "span {:?} outside the text: {}",
                    d.span,
                    context()
                );
            }
            let Some(mut scenario) = scenario else {
                assert!(diagnostics.has_errors(), "rejected silently: {}", context());
                rejected += 1;
                continue;
            };
            scenario.duration = scenario.duration.min(MOST_SAMPLES * scenario.output_step);
            match Simulation::new(&c, &scenario) {
                Err(d) => {
                    assert!(d.has_errors(), "refused silently: {}", context());
                    rejected += 1;
                }
                Ok(simulation) => {
                    ran += 1;
                    // Leaving the finite numbers is an error it reports, never a panic.
                    if let Ok(t) = simulation.run(|_| {}) {
                        assert!(t.values.iter().all(|column| !column.is_empty()));
                    }
                }
            }
        }
    }
    eprintln!("{total} scenario mutants: {rejected} rejected, {ran} simulated");
    assert!(rejected > 0 && ran > 0, "{rejected} rejected, {ran} ran");
}

#[test]
fn mutated_records_never_crash_bgc_residuals() {
    let dir = scratch("fuzz-records");
    let simulated = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "duration 0.4",
        "-e",
        "step 0.001",
        "-e",
        "input U0 = 1 + 0.5*sin(20*t)",
    ]);
    assert_eq!(code(&simulated), 0, "{}", stderr(&simulated));
    let record = simulated.stdout;
    let mut rng = Rng(0xc5f);
    let (mut total, mut rejected) = (0, 0);
    for n in 0..mutants().max(30) {
        let (bytes, what) = mutate(&record, &mut rng);
        let path = dir.join(format!("{n}.csv"));
        std::fs::write(&path, &bytes).expect("write record");
        let shown = path.display().to_string();
        let out = bgc(&["residuals", "models/dc_motor.bg", &shown, "--window", "21"]);
        total += 1;
        let context = || format!("{what}: {}", stderr(&out));
        match code(&out) {
            0 => {
                let written = stdout(&out);
                for word in written.split([',', '\n']) {
                    assert!(
                        !matches!(word, "NaN" | "inf" | "-inf"),
                        "wrote {word}: {}",
                        context()
                    );
                }
            }
            1 | 2 => {
                rejected += 1;
                assert!(stderr(&out).contains("bgc::"), "{}", context());
            }
            other => panic!("exit {other}: {}", context()),
        }
    }
    eprintln!("{total} record mutants through bgc residuals: {rejected} rejected");
    assert!(rejected > 0, "no mutant was rejected");
}
