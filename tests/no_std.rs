//! The runtime without `std`, as a microcontroller's firmware builds it: the crate
//! `bondgraph-no-std` (`#![no_std]`) includes the bench's generated residual code and depends
//! on `bondgraph` without its `std` feature. Cargo unites a package's features across one
//! build, and this suite's build has `std`; so the crate is built by a cargo of its own, in a
//! target directory of its own, and its example runs it on a record here.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{bgc, code, root, scratch, stderr, stdout};

/// Where the `no_std` crate includes the bench's code from.
const INCLUDED: &str = "crates/bondgraph-no-std/src/backlash_bench.rs";

/// The included code is what `bgc models/backlash_bench.bg --emit rust` writes now (with
/// `BGC_UPDATE_GENERATED=1`, this test writes it there).
#[test]
fn the_no_std_crate_includes_what_bgc_writes() {
    let out = bgc(&["models/backlash_bench.bg", "--emit", "rust"]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let path = root().join(INCLUDED);
    if std::env::var_os("BGC_UPDATE_GENERATED").is_some() {
        std::fs::write(&path, stdout(&out)).expect("written");
    }
    let included = std::fs::read_to_string(&path).expect("the included code");
    assert!(
        included == stdout(&out),
        "{INCLUDED} is not what bgc writes now: run `BGC_UPDATE_GENERATED=1 cargo test -p bgc \
         --test suite -- no_std::` and review the diff"
    );
}

/// The bench's generator built without `std` (its `exp`, `tanh`… from `libm`) gives the
/// residuals `bgc residuals` gives on the same healthy record, at the same instants.
#[test]
fn the_bench_without_std_computes_what_bgc_residuals_computes() {
    let dir = scratch("no-std");
    let record = dir.join("healthy.csv").display().to_string();
    let out = bgc(&[
        "simulate",
        "models/backlash_bench.bg",
        "scenarios/bench_dead_zone.scn",
        "--duration",
        "3",
        "-o",
        &record,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let out = bgc(&[
        "residuals",
        "models/backlash_bench.bg",
        &record,
        "--window",
        "21",
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let cli = stdout(&out);
    let firmware = replay(&dir, &record);
    let rows = |csv: &str| -> Vec<Vec<f64>> {
        (csv.lines().skip(1))
            .map(|l| {
                l.split(',')
                    .map(|c| c.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect()
    };
    let header = |csv: &str| csv.lines().next().unwrap_or("").to_string();
    let (theirs, ours) = (rows(&cli), rows(&firmware));
    assert_eq!(theirs.len(), ours.len(), "one row per estimated instant");
    assert!(ours.len() > 2900, "{} rows", ours.len());
    let names: Vec<String> = header(&firmware).split(',').map(str::to_string).collect();
    let cli_names: Vec<String> = header(&cli).split(',').map(str::to_string).collect();
    for (k, name) in names.iter().enumerate() {
        let c = cli_names
            .iter()
            .position(|n| n == name)
            .expect("the CLI's column");
        for (mine, cli) in ours.iter().zip(&theirs) {
            let (a, b) = (mine[k], cli[c]);
            assert!(
                (a - b).abs() <= 1e-9 * a.abs().max(1.0),
                "{name} at t = {}: without std {a}, bgc residuals {b}",
                mine[0]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Builds the `no_std` crate's example with a cargo of its own and runs it on `record`,
/// returning what it prints.
fn replay(dir: &Path, record: &str) -> String {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let target: PathBuf = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-std");
    let out = Command::new(cargo)
        .current_dir(root())
        .args([
            "run",
            "--quiet",
            "--offline",
            "--locked",
            "-p",
            "bondgraph-no-std",
        ])
        .args(["--example", "replay", "--target-dir"])
        .arg(&target)
        .args(["--", record, "0.001", "21"])
        // The suite's own build settings are not the firmware's.
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "the no_std build or its run failed in {}: {}",
        dir.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
