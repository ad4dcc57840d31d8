//! The C backend: every model's code, compiled as strict C99, run over a noisy simulated
//! record, gives the residuals the generated Rust gives, to the bit, and what `bgc residuals`
//! gives: the residuals and thresholds to 1e-12 (the CLI's interpreter evaluates the program
//! with the parameters folded in, and a running value's last bits differ from the generated
//! code's), the alarms and candidates exactly.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{bgc, code, root, stderr, stdout};
use crate::end_to_end::{models, Case};

/// The strict flags the issue asks the code to pass, at `-O1`: GCC's flow warnings
/// (`-Wmaybe-uninitialized`) need an optimising level, and `-O1` compiles the 55 programs in
/// half the time `-O2` takes. The bits do not depend on the level (no contraction into FMAs
/// under `-std=c99`): the comparison with the Rust code's bits holds either way.
const FLAGS: [&str; 6] = [
    "-std=c99",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-pedantic",
    "-O1",
];

/// Each way a model's code is written here: the Rust module's suffix, the options that
/// choose it, and whether its thresholds are adaptive (which needs ARRs realised directly).
const VARIANTS: [(&str, &[&str], bool); 3] = [
    ("", &[], false),
    ("_direct", &["--realise", "direct"], true),
    ("_best", &["--residuals", "best"], false),
];

/// The estimator's window: short enough for every model's record, long enough to smooth.
const WINDOW: &str = "21";

/// One model's C output in one realisation, kept for the comparison with its Rust code.
struct Run {
    /// The Rust module's name: `m_` and the file's stem, with `_direct` for `--realise direct`.
    module: String,
    /// Where its Rust code is.
    rust: PathBuf,
    record: PathBuf,
    step: f64,
    /// The sizes' options (`--noise`, `--size NAME`…), for the Rust replay.
    sizes: Vec<String>,
    c: String,
}

/// How many of its parameters each model's code sizes as written (C and Rust alike).
const SIZED: &str = "2";

#[test]
fn every_model_in_c_computes_what_bgc_residuals_and_the_rust_code_compute() {
    let kept = crate::common::scratch("c-rust");
    let mut runs = Vec::new();
    let mut bench = None;
    for file in models() {
        let case = Case::new(&file, "c");
        let clean = case.simulate("clean.csv", &[]);
        let mut noise = case.noise(&case.peaks(&clean));
        noise.push("seed 7".to_string());
        let stem = file.trim_end_matches(".bg").to_string();
        let record = kept.join(format!("{stem}.csv"));
        std::fs::copy(case.simulate("noisy.csv", &noise), &record).expect("copied");
        let record_arg = record.display().to_string();
        let step = record_step(&record_arg);
        for (suffix, choice, adaptive) in VARIANTS {
            // `best` is tried where it runs a copy of the model (simulated residuals).
            let Some(replay) =
                compile(&case, &format!("{stem}{suffix}"), choice, suffix != "_best")
            else {
                continue;
            };
            let run = |options: &[String]| {
                let out = Command::new(&replay)
                    .arg(&record)
                    .arg(step.to_string())
                    .arg(WINDOW)
                    .args(options)
                    .output()
                    .expect("the replay runs");
                assert!(
                    out.status.success(),
                    "{file}: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
                String::from_utf8_lossy(&out.stdout).into_owned()
            };
            let first = run(&[]);
            let mut options = thresholds(&first);
            options.extend(["--debounce".to_string(), "3".to_string()]);
            if adaptive {
                options.push("--adaptive".to_string());
            }
            let cli = residuals(&case, &record_arg, choice, &options);
            // As written, the first parameters the residuals read are sized too, weighted by
            // the residuals' RMS on this healthy record.
            let noise = ["--noise".to_string(), rms(&first)];
            if suffix.is_empty() {
                options.extend(noise.clone());
                options.extend(["--sizes".to_string(), SIZED.to_string()]);
            }
            if file == "backlash_bench.bg" && suffix.is_empty() {
                // Kept beyond the case's directory, which goes with it.
                let (program, faulty) = (kept.join("bench-replay"), kept.join("faulty.csv"));
                std::fs::copy(&replay, &program).expect("copied");
                std::fs::copy(case.simulate("faulty.csv", &[FAULT.to_string()]), &faulty)
                    .expect("copied");
                bench = Some((program, faulty, noise[1].clone(), step));
            }
            let c = run(&options);
            let what = format!("{file} {choice:?} (adaptive: {adaptive})");
            compare(&what, &cli, &c, 1e-12);
            // The generated Rust's bits, as written and where a copy runs: the realisation
            // direct reads the same code paths (and its crate would take as long again).
            if suffix == "_direct" {
                continue;
            }
            let module = format!("m_{stem}{suffix}");
            let rust = kept.join(format!("{module}.rs"));
            let mut args = vec![case.model.as_str(), "--emit", "rust", "-o"];
            let rust_arg = rust.display().to_string();
            args.push(&rust_arg);
            args.extend(choice);
            let out = bgc(&args);
            assert_eq!(code(&out), 0, "{file}: {}", stderr(&out));
            let mut sizes = noise.to_vec();
            sizes.extend(
                sized(&c)
                    .into_iter()
                    .flat_map(|p| ["--size".to_string(), p]),
            );
            runs.push(Run {
                module,
                rust,
                record: record.clone(),
                step,
                sizes: if suffix.is_empty() { sizes } else { Vec::new() },
                c,
            });
        }
    }
    runs.push(faulty_bench(bench.expect("the bench is a model"), &kept));
    let program = rust_replay(&kept, &runs);
    for run in &runs {
        let out = Command::new(&program)
            .arg(&run.module)
            .arg(&run.record)
            .arg(run.step.to_string())
            .arg(WINDOW)
            .args(&run.sizes)
            .output()
            .expect("the Rust replay runs");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let rust = String::from_utf8_lossy(&out.stdout);
        // The same operations in the same order: the same bits.
        compare(&run.module, &rust, &run.c, 0.0);
    }
    let _ = std::fs::remove_dir_all(&kept);
}

/// The bench's fault sized in C and Rust alike: its dead zone tripled early in the record.
const FAULT: &str = "fault j0 = 3*j0 at 1";

/// The bench's code as written over a record of its dead zone tripled, sizing `j0` and `Re`
/// (the bench's program, that record, the residuals' healthy RMS, the step): the C code
/// follows the dead zone past its linearisation, and the run is kept for the comparison
/// with the Rust runtime's `FaultSize`.
fn faulty_bench(bench: (PathBuf, PathBuf, String, f64), kept: &Path) -> Run {
    let (program, record, noise, step) = bench;
    let sizes: Vec<String> = ["--noise", &noise, "--size", "j0", "--size", "Re"]
        .map(String::from)
        .to_vec();
    let out = Command::new(&program)
        .arg(&record)
        .arg(step.to_string())
        .arg(WINDOW)
        .args(&sizes)
        .output()
        .expect("the replay runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c = String::from_utf8_lossy(&out.stdout).into_owned();
    let header: Vec<&str> = c.lines().next().unwrap_or("").split(',').collect();
    let column = header
        .iter()
        .position(|h| *h == "size_j0")
        .expect("j0 sized");
    let last = c.lines().last().unwrap_or("").split(',').nth(column);
    let j0: f64 = last.and_then(|v| v.parse().ok()).expect("an estimate");
    assert!((j0 / 0.6 - 1.0).abs() < 0.1, "j0 sized {j0}, truth 0.6");
    Run {
        module: "m_backlash_bench".to_string(),
        rust: kept.join("m_backlash_bench.rs"),
        record,
        step,
        sizes,
        c,
    }
}

/// The parameters a replay's output sizes, by its `size_NAME` columns.
fn sized(output: &str) -> Vec<String> {
    (output.lines().next().unwrap_or("").split(','))
        .filter_map(|h| h.strip_prefix("size_"))
        .filter(|h| !h.ends_with("_half_width") && !h.ends_with("_misfit"))
        .map(String::from)
        .collect()
}

/// Each residual's RMS in a replay's output, comma separated (1 where it is 0): the noise
/// levels the sizes weigh them by.
fn rms(output: &str) -> String {
    let header: Vec<&str> = output.lines().next().unwrap_or("").split(',').collect();
    let count = (header.iter().skip(1))
        .take_while(|h| !h.starts_with("threshold_"))
        .count();
    let mut sums = vec![(0.0_f64, 0.0_f64); count];
    for line in output.lines().skip(1) {
        for (cell, sum) in line.split(',').skip(1).zip(&mut sums) {
            if let Ok(v) = cell.parse::<f64>() {
                if v.is_finite() {
                    *sum = (sum.0 + v * v, sum.1 + 1.0);
                }
            }
        }
    }
    let levels: Vec<String> = (sums.iter())
        .map(|&(s, n)| {
            if s > 0.0 {
                format!("{:?}", (s / n).sqrt())
            } else {
                "1.0".to_string()
            }
        })
        .collect();
    levels.join(",")
}

/// A crate that includes every run's Rust code, built by a cargo of its own: its program
/// replays a record through the generator of the module named first.
fn rust_replay(dir: &Path, runs: &[Run]) -> PathBuf {
    let krate = dir.join("rust-replay");
    std::fs::create_dir_all(krate.join("src")).expect("crate dir");
    let manifest = format!(
        "[package]\nname = \"rust-replay\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n[dependencies]\nbondgraph = {{ path = \"{}\" }}\n\n[workspace]\n",
        root().join("crates/bondgraph").display()
    );
    std::fs::write(krate.join("Cargo.toml"), manifest).expect("manifest");
    std::fs::copy(root().join("Cargo.lock"), krate.join("Cargo.lock")).expect("lock");
    let mut main = String::from(RUST_REPLAY);
    let mut arms = String::new();
    let mut included = std::collections::BTreeSet::new();
    // The faulty bench's run reads the bench's module again.
    for run in runs.iter().filter(|r| included.insert(r.module.clone())) {
        main += &format!(
            "#[allow(non_snake_case, clippy::all)]\nmod {} {{\n    include!({:?});\n}}\n",
            run.module, run.rust
        );
        arms += &format!(
            "        {:?} => replay!({}, header, rows, step, window, sizes, noise),\n",
            run.module, run.module
        );
    }
    main += &format!(
        "fn run(model: &str, header: &[String], rows: &[Vec<f64>], step: f64, window: usize, sizes: &[String], noise: &[f64]) -> String {{\n    match model {{\n{arms}        _ => panic!(\"no model {{model}}\"),\n    }}\n}}\n"
    );
    std::fs::write(krate.join("src/main.rs"), main).expect("main");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rust-replay");
    let out = Command::new(cargo)
        .current_dir(&krate)
        .args(["build", "--quiet", "--offline", "--target-dir"])
        .arg(&target)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        // No debug information: a fresh build (CI's) takes a third less.
        .env("CARGO_PROFILE_DEV_DEBUG", "0")
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "the Rust replay does not build: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    target.join("debug/rust-replay")
}

/// The Rust replay's fixed part: reading the record, and one generator's run as a macro.
const RUST_REPLAY: &str = r#"
macro_rules! replay {
    ($m:ident, $header:expr, $rows:expr, $step:expr, $window:expr, $sizes:expr, $noise:expr) => {{
        use $m::*;
        let degree = CHANNEL_ORDERS.iter().copied().max().unwrap_or(0).max(3);
        let mut g = ResidualGenerator::savitzky_golay(Params::default(), $step, $window, degree)
            .expect("a generator");
        let mut sized: Vec<(&String, bondgraph::FaultSize<ResidualGenerator>)> = ($sizes.iter())
            .map(|name: &String| {
                let k = Params::NAMES.iter().position(|n| n == name).expect("a parameter");
                let size = bondgraph::FaultSize::new(&g, k, $noise, 2000).expect("a size");
                (name, size.with_correlation($window))
            })
            .collect();
        let column = |name: &str| $header.iter().position(|h| h == name).expect(name);
        let time = column("t");
        let raw: Vec<usize> = RAW_SIGNALS.iter().map(|s| column(s)).collect();
        let mut out = String::from("t");
        for name in RESIDUALS {
            out += ",";
            out += name;
        }
        for (name, _) in &sized {
            out += &format!(",size_{name},size_{name}_half_width,size_{name}_misfit");
        }
        out += "
";
        for row in $rows {
            let sample: [f64; RAW_SIGNALS.len()] = core::array::from_fn(|i| row[raw[i]]);
            for (_, size) in &mut sized {
                size.push(row[time], &sample);
            }
            if let Some(r) = g.push(row[time], sample) {
                out += &format!("{:?}", row[time] - g.delay());
                for v in r {
                    if v.is_nan() { out += ","; } else { out += &format!(",{v:?}"); }
                }
                for (_, size) in &sized {
                    let e = size.estimate();
                    out += &format!(",{:?},{:?},{:?}", e.value, e.half_width, e.misfit);
                }
                out += "
";
            }
        }
        out
    }};
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let text = std::fs::read_to_string(&args[1]).expect("record");
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().expect("header").split(',').map(String::from).collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    let step: f64 = args[2].parse().expect("step");
    let window: usize = args[3].parse().expect("window");
    let (mut sizes, mut noise) = (Vec::new(), Vec::new());
    let mut options = args[4..].iter();
    while let Some(option) = options.next() {
        let value = options.next().expect("a value");
        match option.as_str() {
            "--size" => sizes.push(value.clone()),
            "--noise" => noise = value.split(',').map(|v| v.parse().expect("a level")).collect(),
            _ => panic!("unknown option {option}"),
        }
    }
    print!("{}", run(&args[0], &header, &rows, step, window, &sizes, &noise));
}

"#;

/// The step of a uniform record as `bgc residuals` takes it: its first interval (the median
/// but for the last bits of decimal time stamps).
fn record_step(record: &str) -> f64 {
    let text = std::fs::read_to_string(record).expect("record");
    let t: Vec<f64> = (text.lines().skip(1).take(2))
        .map(|l| l.split(',').next().unwrap_or("").parse().expect("time"))
        .collect();
    t[1] - t[0]
}

/// `--threshold` options at about each residual's median |value| in `residuals` (a CSV of
/// `t` and the residuals first), so that its alarm rises and falls all along the record.
fn thresholds(residuals: &str) -> Vec<String> {
    let header: Vec<&str> = residuals
        .lines()
        .next()
        .expect("header")
        .split(',')
        .collect();
    let names: Vec<&str> = (header.iter().skip(1))
        .take_while(|h| !h.starts_with("threshold_"))
        .copied()
        .collect();
    let mut options = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let mut values: Vec<f64> = (residuals.lines().skip(1))
            .filter_map(|l| l.split(',').nth(1 + k)?.parse::<f64>().ok())
            .map(f64::abs)
            .filter(|v| v.is_finite())
            .collect();
        values.sort_by(f64::total_cmp);
        // Between two values, not at one: a value at the threshold itself would be above
        // or not by the last bit, which the two implementations may round apart.
        let m = values.len() / 2;
        if let (Some(&a), Some(&b)) = (values.get(m), values.get(m + 1)) {
            options.push("--threshold".to_string());
            options.push(format!("{name}={}", 0.5 * (a + b)));
        }
    }
    options
}

/// What `bgc residuals` prints with the residuals `choice` and `options`.
fn residuals(case: &Case, record: &str, choice: &[&str], options: &[String]) -> String {
    let mut args = vec![
        "residuals",
        case.model.as_str(),
        record,
        "--window",
        WINDOW,
        "--no-size",
    ];
    args.extend(choice);
    args.extend(options.iter().map(String::as_str));
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{}: {}", case.model, stderr(&out));
    stdout(&out)
}

/// The model's C code (as `choice` asks) with the replay driver, compiled with [`FLAGS`]:
/// the program's path; `None`, not compiled, where the code runs no copy of the model and
/// `always` is not set.
fn compile(case: &Case, stem: &str, choice: &[&str], always: bool) -> Option<PathBuf> {
    let source = case.dir.join(format!("{stem}.c"));
    let source_arg = source.display().to_string();
    let mut args = vec![case.model.as_str(), "--emit", "c", "-o", &source_arg];
    args.extend(choice);
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{stem}: {}", stderr(&out));
    let copy = std::fs::read_to_string(&source)
        .expect("the source")
        .contains("_copy_rates(");
    if !always && !copy {
        return None;
    }
    // The prefix of the code's names: the model's name, as the header's types carry it.
    let header = std::fs::read_to_string(source.with_extension("h")).expect("the header");
    let prefix = (header.lines())
        .find_map(|l| l.strip_prefix("} ")?.strip_suffix("_params;"))
        .expect("the parameters' type")
        .to_string();
    let program = case.dir.join(format!("{stem}-replay"));
    let out = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".to_string()))
        .args(FLAGS)
        .arg(format!("-DBGC_HEADER=\"{stem}.h\""))
        .arg(format!("-DBGC_PREFIX={prefix}"))
        .arg(format!("-DBGC_UPPER={}", prefix.to_ascii_uppercase()))
        .arg("-I")
        .arg(&case.dir)
        .arg(&source)
        .arg(root().join("tests/c/replay.c"))
        .args(["-lm", "-o"])
        .arg(&program)
        .output()
        .expect("a C compiler (cc, or $CC) runs");
    assert!(
        out.status.success(),
        "{stem}: the C code does not compile with {FLAGS:?}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(program)
}

/// `other`'s columns agree with `reference`'s of the same name: numbers to `tolerance`,
/// absolute where the column stays under 1 and relative to its largest value above (time to
/// 1e-9 s), alarms and candidates exactly.
fn compare(what: &str, reference: &str, other: &str, tolerance: f64) {
    let table = |csv: &str| -> (Vec<String>, Vec<Vec<String>>) {
        let mut lines = csv.lines();
        let header = (lines.next().unwrap_or("").split(','))
            .map(str::to_string)
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        (header, rows)
    };
    let ((ref_header, ref_rows), (header, rows)) = (table(reference), table(other));
    assert_eq!(ref_rows.len(), rows.len(), "{what}: rows");
    assert!(rows.len() > 1000, "{what}: {} rows", rows.len());
    // The columns both print: the CLI's suspects and episodes are not the C code's.
    let common: Vec<(usize, usize)> = (ref_header.iter().enumerate())
        .filter_map(|(j, name)| Some((j, header.iter().position(|h| h == name)?)))
        .collect();
    assert!(
        common.len() >= 2,
        "{what}: {header:?} against {ref_header:?}"
    );
    for (j, k) in common {
        let name = &ref_header[j];
        let exact = name.starts_with("alarm_") || name == "candidates";
        let scale = (ref_rows.iter())
            .filter_map(|r| r.get(j)?.parse::<f64>().ok())
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        for (mine, theirs) in rows.iter().zip(&ref_rows) {
            let (a, b) = (&mine[k], &theirs[j]);
            if exact || a.is_empty() || b.is_empty() {
                assert_eq!(a, b, "{what}: {name} at t = {}", theirs[0]);
                continue;
            }
            let (x, y): (f64, f64) = (a.parse().expect("number"), b.parse().expect("number"));
            if x == y {
                // Infinities too (a size's interval before it is known).
                continue;
            }
            let bound = if name == "t" {
                1e-9
            } else {
                tolerance * scale.max(1.0)
            };
            assert!(
                (x - y).abs() <= bound,
                "{what}: {name} at t = {}: C {x}, reference {y} (scale {scale})",
                theirs[0]
            );
        }
    }
}

/// The generated header and source are what `bgc` writes to standard output as one file.
#[test]
fn the_single_file_is_the_header_and_the_source() {
    let dir = crate::common::scratch("c-single");
    let source = dir.join("bench.c");
    let out = bgc(&[
        "models/backlash_bench.bg",
        "--emit",
        "c",
        "-o",
        &source.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let header = std::fs::read_to_string(dir.join("bench.h")).expect("the header");
    let text = std::fs::read_to_string(&source).expect("the source");
    assert!(text.contains("#include \"bench.h\""));
    assert!(header.contains("int backlash_bench_push(backlash_bench_generator *g"));
    let out = bgc(&["models/backlash_bench.bg", "--emit", "c", "-o", "bench.txt"]);
    assert_eq!(code(&out), 2, "{}", stderr(&out));
    assert!(stderr(&out).contains("ending in .c"), "{}", stderr(&out));
    // An FMU is an archive: never to standard output, only to a `.fmu`.
    for args in [&["-o", "bench.zip"][..], &[][..]] {
        let mut full = vec!["models/backlash_bench.bg", "--emit", "fmu"];
        full.extend(args);
        let out = bgc(&full);
        assert_eq!(code(&out), 2, "{}", stderr(&out));
        assert!(stderr(&out).contains("ending in .fmu"), "{}", stderr(&out));
        assert!(out.stdout.is_empty());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
