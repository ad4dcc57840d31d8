//! `bgc residuals` on a million rows of the bench (1,000 s at 1 kHz, noise on both
//! encoders), as a user runs it: the whole command, reading the CSV and writing the residuals,
//! with each realisation, with modulating functions, and with the windows `--calibrate`
//! chooses.

use std::path::{Path, PathBuf};
use std::process::Command;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

const ROWS: u64 = 1_000_001;

fn bgc() -> Command {
    Command::new(env!("CARGO_BIN_EXE_bgc"))
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Simulates the bench into `dir`, with `seed`.
fn record(dir: &Path, name: &str, seed: u32) -> PathBuf {
    let path = dir.join(name);
    let status = bgc()
        .current_dir(root())
        .args([
            "simulate",
            "models/backlash_bench.bg",
            "scenarios/bench_dead_zone.scn",
        ])
        .args(["--duration", "1000", "--seed", &seed.to_string(), "-o"])
        .arg(&path)
        .status()
        .expect("bgc runs");
    assert!(status.success());
    path
}

fn residuals(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("bgc-bench-residuals-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let data = record(&dir, "bench.csv", 2);
    let healthy = record(&dir, "healthy.csv", 1);
    let out = dir.join("r.csv");
    let mut group = c.benchmark_group("bgc_residuals");
    group.sample_size(10);
    group.throughput(Throughput::Elements(ROWS));
    let runs: [(&str, Vec<&str>); 4] = [
        ("integrated_window_201", vec!["--window", "201"]),
        (
            "integrated_modulating_201",
            vec!["--window", "201", "--estimator", "modulating"],
        ),
        (
            "direct_window_201",
            vec!["--window", "201", "--realise", "direct"],
        ),
        ("calibrated", vec!["--calibrate"]),
    ];
    for (name, args) in runs {
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut command = bgc();
                command.current_dir(root());
                command
                    .args(["residuals", "models/backlash_bench.bg"])
                    .arg(&data);
                command.args(&args);
                if args.contains(&"--calibrate") {
                    command.arg(&healthy);
                }
                let status = command.arg("-o").arg(&out).status().expect("bgc runs");
                assert!(status.success());
            })
        });
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, residuals);
criterion_main!(benches);
