//! The command line: help, version, exit codes, output files.

use crate::common::{bgc, code, root, scratch, stderr, stdout};

#[test]
fn help_and_version() {
    let help = bgc(&["--help"]);
    assert_eq!(code(&help), 0);
    for word in ["--emit", "-o, --output", "check", "MODEL"] {
        assert!(
            stdout(&help).contains(word),
            "help lacks {word}:\n{}",
            stdout(&help)
        );
    }
    let version = bgc(&["--version"]);
    assert_eq!(code(&version), 0);
    assert_eq!(
        stdout(&version).trim(),
        format!("bgc {}", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn an_unknown_target_is_a_usage_error_listing_the_valid_ones() {
    let out = bgc(&["models/dc_motor.bg", "--emit", "svgz"]);
    assert_eq!(code(&out), 2);
    assert!(
        stderr(&out).contains("possible values: text, json, latex, state, dot"),
        "{}",
        stderr(&out)
    );
    assert!(stdout(&out).is_empty());
}

#[test]
fn standalone_is_only_for_latex() {
    let out = bgc(&["models/dc_motor.bg", "--emit", "json", "--standalone"]);
    assert_eq!(code(&out), 2);
    assert!(stderr(&out).contains("--standalone"), "{}", stderr(&out));
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(code(&bgc(&[])), 2);
    assert_eq!(code(&bgc(&["--frobnicate", "models/dc_motor.bg"])), 2);
    let missing = bgc(&["check", "models/no_such_model.bg"]);
    assert_eq!(code(&missing), 2);
    assert!(
        stderr(&missing).contains("no_such_model.bg"),
        "{}",
        stderr(&missing)
    );
    assert_eq!(
        code(&bgc(&["check", "models"])),
        2,
        "a directory is not a model"
    );
}

#[test]
fn an_invalid_model_exits_1_and_writes_nothing() {
    let dir = scratch("cli");
    let bad = dir.join("bad.bg");
    std::fs::write(&bad, "model bad\nSe s = 1\ns -> r\n").expect("write");
    let out_file = dir.join("out.dot");
    let out = bgc(&[
        bad.to_str().expect("utf-8 path"),
        "--emit",
        "dot",
        "-o",
        out_file.to_str().expect("utf-8 path"),
    ]);
    assert_eq!(code(&out), 1);
    assert!(stdout(&out).is_empty());
    assert!(!out_file.exists(), "no output file for an invalid model");
    assert!(stderr(&out).contains("bad.bg:3:6"), "{}", stderr(&out));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn output_goes_to_the_file_given_with_o() {
    let dir = scratch("cli-o");
    let file = dir.join("bench.dot");
    let out = bgc(&[
        "models/backlash_bench.bg",
        "--emit",
        "dot",
        "-o",
        file.to_str().expect("utf-8 path"),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(stdout(&out).is_empty());
    let written = std::fs::read_to_string(&file).expect("written");
    let direct = bgc(&["models/backlash_bench.bg", "--emit", "dot"]);
    assert_eq!(written, stdout(&direct));
    assert!(written.starts_with("digraph \"backlash_bench\""));
    std::fs::remove_dir_all(&dir).ok();
    assert!(root().join("models/backlash_bench.bg").exists());
}

/// `-o` writes through a link and into what is not a file (a named pipe here, `/dev/null` for
/// a user): the atomic rename once replaced `/dev/null` with a regular file when run as root.
#[cfg(unix)]
#[test]
fn o_writes_through_links_and_into_pipes_without_replacing_them() {
    use std::os::unix::fs::FileTypeExt as _;
    let dir = scratch("cli-o-special");
    let direct = stdout(&bgc(&["models/backlash_bench.bg", "--emit", "dot"]));
    let real = dir.join("real.dot");
    let link = dir.join("link.dot");
    std::fs::write(&real, "old").expect("write");
    std::os::unix::fs::symlink(&real, &link).expect("symlink");
    let out = bgc(&[
        "models/backlash_bench.bg",
        "--emit",
        "dot",
        "-o",
        &link.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let meta = std::fs::symlink_metadata(&link).expect("link");
    assert!(
        meta.file_type().is_symlink(),
        "the link was replaced by a file"
    );
    assert_eq!(std::fs::read_to_string(&real).expect("real"), direct);

    let fifo = dir.join("pipe.dot");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        return; // no mkfifo on this system
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo))
    };
    let out = bgc(&[
        "models/backlash_bench.bg",
        "--emit",
        "dot",
        "-o",
        &fifo.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let kind = std::fs::symlink_metadata(&fifo).expect("fifo").file_type();
    // Checked before joining: had bgc renamed a file over the pipe, the reader would wait on
    // the pipe for ever.
    assert!(kind.is_fifo(), "the named pipe was replaced by a file");
    let read = reader.join().expect("reader").expect("read the pipe");
    assert_eq!(read, direct);
    std::fs::remove_dir_all(&dir).ok();
}

/// Four bgc writing one `-o` at the same moment: each stages its own file, so every one
/// succeeds and the file is always one whole output. With one staging name for all, 22 of 80
/// writers failed ("No such file or directory") and one file in 20 mixed two outputs.
#[cfg(unix)]
#[test]
fn four_writers_of_one_file_leave_one_whole_output() {
    let dir = scratch("cli-o-race");
    let target = dir.join("same.txt");
    let emits = ["dot", "text", "json", "latex"];
    let outputs: Vec<String> = emits
        .iter()
        .map(|e| stdout(&bgc(&["models/backlash_bench.bg", "--emit", e])))
        .collect();
    for _ in 0..6 {
        let writers: Vec<_> = emits
            .iter()
            .map(|e| {
                std::process::Command::new(env!("CARGO_BIN_EXE_bgc"))
                    .args(["models/backlash_bench.bg", "--emit", e, "-o"])
                    .arg(&target)
                    .current_dir(root())
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .expect("bgc runs")
            })
            .collect();
        for w in writers {
            let out = w.wait_with_output().expect("bgc ends");
            assert_eq!(code(&out), 0, "{}", stderr(&out));
        }
        let written = std::fs::read_to_string(&target).expect("written");
        assert!(outputs.contains(&written), "a mix of outputs was left");
        assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A write cut short, by a full disk (here a file-size limit, whose signal is ignored, so that
/// the write fails as on a full disk) or by the process being killed mid-write (the same limit,
/// whose signal kills), leaves the old file as it was and no staging file beside it: for `-o`
/// and for `--plot` alike. An SVG was drawn straight into its file, truncated on a full disk
/// and left empty by a kill.
#[cfg(target_os = "linux")]
#[test]
fn a_write_cut_short_leaves_the_old_file_and_nothing_else() {
    let dir = scratch("cli-o-cut");
    let bin = env!("CARGO_BIN_EXE_bgc");
    for (option, name) in [("-o", "run.csv"), ("--plot", "run.svg")] {
        let file = dir.join(name);
        let command = format!(
            "{bin} simulate models/dc_motor.bg -e 'input U0 = 12' --duration 1 {option} {}",
            file.display()
        );
        for (how, shell) in [
            (
                "a full disk",
                format!("trap '' XFSZ; ulimit -f 8; exec {command}"),
            ),
            ("a kill", format!("ulimit -f 8; exec {command} > /dev/null")),
        ] {
            std::fs::write(&file, "old").expect("write");
            let out = std::process::Command::new("sh")
                .args(["-c", &shell])
                .current_dir(root())
                .output()
                .expect("sh runs");
            assert!(!out.status.success(), "{option}, {how}: not cut short");
            let kept = std::fs::read_to_string(&file).expect("kept");
            assert_eq!(kept, "old", "{option}, {how}");
            let left = std::fs::read_dir(&dir).expect("dir").count();
            assert_eq!(left, 1, "{option}, {how}: a staging file was left");
        }
        std::fs::remove_file(&file).expect("removed");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The e-graph only changes how expressions are written: `--canonical` shows the expanded
/// forms, and an expression over `--egg-nodes` is shown canonical with a warning.
#[test]
fn simplification_limits_are_options_and_what_they_skip_is_said() {
    let model = "models/quarter_car.bg";
    let state = |extra: &[&str]| {
        let mut args = vec![model, "--emit", "state"];
        args.extend(extra);
        bgc(&args)
    };
    let simplified = state(&[]);
    let canonical = state(&["--canonical"]);
    assert_eq!((code(&simplified), code(&canonical)), (0, 0));
    assert!(stdout(&simplified).contains("cs * (p_body / ms - p_wheel / mu)"));
    assert!(stdout(&canonical).contains("- p_wheel * cs / mu"));
    assert!(stderr(&canonical).is_empty());

    let tiny = state(&["--egg-nodes", "3"]);
    assert_eq!(code(&tiny), 0);
    assert_eq!(stdout(&tiny), stdout(&canonical));
    assert!(
        stderr(&tiny)
            .contains("⚠ der(p_wheel) is shown in canonical form: it is larger than --egg-nodes"),
        "{}",
        stderr(&tiny)
    );

    // The budget is shared: ARRs come first, so after the first ARR's search the state
    // equations are left as they are.
    let budget = bgc(&[model, "--emit", "json", "--egg-budget", "1"]);
    assert_eq!(code(&budget), 0);
    assert!(
        stderr(&budget).contains(
            "⚠ 7 expressions, from ARR2 on, are shown in canonical form: --egg-budget was spent"
        ),
        "{}",
        stderr(&budget)
    );

    // The clock is not a limit: `--egg-seconds` (once 10 s, whose expiry under load failed
    // shipped models, and whose 0 failed every model) is accepted, said to be unused, and
    // changes nothing.
    let plain = state(&[]);
    for seconds in ["0", "inf", "nan"] {
        let old = state(&["--egg-seconds", seconds]);
        assert_eq!(code(&old), 0, "{}", stderr(&old));
        assert_eq!(old.stdout, plain.stdout);
        assert!(
            stderr(&old).contains("--egg-seconds is no longer used"),
            "{}",
            stderr(&old)
        );
    }
}

/// A model whose `let`s form a chain (each uses the one before) is handled in time linear in
/// its length and without deep recursion: 20,000 of them, as sums and as products.
#[test]
fn long_let_chains_neither_overflow_the_stack_nor_take_quadratic_time() {
    let dir = scratch("cli-lets");
    let base = std::fs::read_to_string(root().join("models/rlc_series.bg")).expect("model");
    for op in ["+", "*"] {
        let n = 20_000;
        let mut lets = String::from("let a0 = R1\n");
        for i in 1..n {
            lets.push_str(&format!("let a{i} = a{} {op} R1\n", i - 1));
        }
        let text = base
            .replace("Se src = V", &format!("{lets}Se src = V"))
            .replace("R  res = R1", &format!("R  res = a{}", n - 1));
        let file = dir.join(format!(
            "chain{}.bg",
            if op == "+" { "sum" } else { "product" }
        ));
        std::fs::write(&file, text).expect("written");
        let out = bgc(&[file.to_str().expect("utf-8 path"), "--emit", "json"]);
        assert_eq!(code(&out), 0, "{op}: {}", stderr(&out));
        let expected = if op == "+" {
            "20000 * R1"
        } else {
            "R1 ^ 20000"
        };
        assert!(stdout(&out).contains(expected), "{op}: {}", stdout(&out));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn verify_checks_a_model_and_says_so() {
    let out = bgc(&["verify", "models/dc_motor.bg"]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let table = stdout(&out);
    assert!(table.contains("ARR1") && table.contains("pass"), "{table}");
    assert!(table.trim_end().ends_with("0 failed"), "{table}");
}

/// `bgc simulate` writes CSV: a header of time, inputs, states and measured signals, one row
/// per output step, the same bytes on every run (the noise is seeded).
#[test]
fn simulate_writes_the_same_csv_every_time() {
    let args = [
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "duration 0.5",
        "-e",
        "step 0.01",
        "-e",
        "input U0 = 12*(t >= 0)",
        "-e",
        "noise y1 0.01",
    ];
    // `>=` is not in the language: the statement is reported where it is wrong.
    let wrong = bgc(&args);
    assert_eq!(code(&wrong), 1, "{}", stderr(&wrong));
    assert!(
        stderr(&wrong).contains("<command line>:3:"),
        "{}",
        stderr(&wrong)
    );
    let mut args = args;
    args[7] = "input U0 = 12";
    let first = bgc(&args);
    assert_eq!(code(&first), 0, "{}", stderr(&first));
    let csv = stdout(&first);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("t,U0,p_Lm,p_Jm,i,y1"), "{csv}");
    assert_eq!(lines.count(), 51);
    assert_eq!(stdout(&bgc(&args)), csv, "deterministic");
    let unknown = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "input U0 = 1",
        "-e",
        "fault Rx = 2 at 1",
    ]);
    assert_eq!(code(&unknown), 1);
    assert!(
        stderr(&unknown).contains("`Rx` is not a parameter of `dc_motor`")
            && stderr(&unknown).contains("did you mean `Re`?"),
        "{}",
        stderr(&unknown)
    );
}

/// Past 30 ARRs the FSM is written by row, by default, in JSON (each row's `arrs`, with a note
/// saying so) and in LaTeX (a column of ARR names, not one column per ARR): the dense forms
/// grow with the square of the model (203 MB and 264 MB at 10,000 stages; at 50,000 the JSON
/// did not fit in 16 GB). `--fsm dense` still writes the dense JSON.
#[test]
fn a_large_models_fsm_is_written_by_row() {
    let dir = scratch("cli-sparse");
    let model = dir.join("chain.bg");
    std::fs::write(&model, bondgraph_core::generate::mass_spring_chain(160, 5)).expect("w");
    let path = model.display().to_string();
    let auto = bgc(&[&path, "--emit", "json", "--canonical"]);
    assert_eq!(code(&auto), 0, "{}", stderr(&auto));
    assert!(
        stderr(&auto).contains("the FSM is written sparse"),
        "{}",
        stderr(&auto)
    );
    let json: serde_json::Value = serde_json::from_str(&stdout(&auto)).expect("JSON");
    let row = &json["fsm"]["rows"][0];
    assert!(
        row.get("signature").is_none() && row["arrs"].is_array(),
        "{row}"
    );
    let dense = bgc(&[&path, "--emit", "json", "--canonical", "--fsm", "dense"]);
    assert!(!stderr(&dense).contains("the FSM is written sparse"));
    let json: serde_json::Value = serde_json::from_str(&stdout(&dense)).expect("JSON");
    assert_eq!(
        json["fsm"]["rows"][0]["signature"].as_array().map(Vec::len),
        Some(32)
    );
    let latex = stdout(&bgc(&[&path, "--emit", "latex", "--canonical"]));
    assert!(latex.contains("\\begin{tabular}{lcclcc}"), "{latex}");
    assert!(latex.contains("ARRs are too many for a column each"));
    std::fs::remove_dir_all(&dir).ok();
}

/// The textbook quadratic loss `e = kl*f*abs(f)` (and `sign(f)*f^2`) is read the other way in
/// closed form, as `kl*sign(f)*abs(f)^2` was: the tank drained through it simulates from
/// rest. It was held as a nonlinear loop whose Newton step divides by the flow, 0 at rest, and
/// the run failed with "check the laws' signs, or shorten `step`".
#[test]
fn a_textbook_quadratic_loss_is_inverted_and_simulates_from_rest() {
    let dir = scratch("cli-loss");
    let base = std::fs::read_to_string(root().join("models/orifice_tank.bg")).expect("model");
    for law in ["e = kl*f*abs(f)", "e = sign(f)*f^2*kl"] {
        let text = base
            .replace("R  drain : f = c*sqrt(e)", &format!("R  drain : {law}"))
            .replace(
                "param c   = 1.5e-6 [m^3/s/Pa^0.5]    \"orifice coefficient\"",
                "param kl = 4e11",
            );
        assert!(text.contains(law) && text.contains("param kl"), "{text}");
        let model = dir.join("tank.bg");
        std::fs::write(&model, &text).expect("w");
        let path = model.display().to_string();
        let out = bgc(&[&path, "--emit", "state"]);
        assert_eq!(code(&out), 0, "{law}: {}", stderr(&out));
        assert!(
            !stdout(&out).contains("solved numerically"),
            "{law}: {}",
            stdout(&out)
        );
        let run = bgc(&[
            "simulate",
            &path,
            "-e",
            "duration 5",
            "-e",
            "input Qin = 1e-3",
        ]);
        assert_eq!(code(&run), 0, "{law}: {}", stderr(&run));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The README's first command prints no warning: the bench's ratio `N`, read by the gear and
/// by the load-side coupling on purpose, is marked `shared`. Without the mark the warning
/// comes back, and the output lists the shared parameter either way.
#[test]
fn a_parameter_marked_shared_is_not_warned_about() {
    let out = bgc(&["models/backlash_bench.bg"]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(
        !stderr(&out).contains("bg::shared-parameter"),
        "{}",
        stderr(&out)
    );
    let dir = scratch("cli-shared");
    let text = std::fs::read_to_string(root().join("models/backlash_bench.bg")).expect("model");
    let unmarked = text.replace(" shared \"reduction", " \"reduction");
    assert_ne!(unmarked, text);
    let model = dir.join("bench.bg");
    std::fs::write(&model, unmarked).expect("w");
    let again = bgc(&[&model.display().to_string()]);
    assert!(
        stderr(&again).contains("bg::shared-parameter"),
        "{}",
        stderr(&again)
    );
    assert!(stderr(&again).contains("silences"), "{}", stderr(&again));
    assert_eq!(stdout(&again), stdout(&out), "the mark changes no output");
    std::fs::remove_dir_all(&dir).ok();
}

/// A run that stops says where its cause is written: an input whose expression has no value
/// is located at the scenario's line that defines it (it was "`U0` is not a finite number at
/// t = 0 s" against the model's file), and a state whose derivative is not a number at the
/// start is named (the solver said "more than 1000000 steps" or "Initial step size (0.0)
/// cannot be zero").
#[test]
fn a_run_that_stops_points_at_its_cause() {
    let dir = scratch("cli-stops");
    let scenario = dir.join("log.scn");
    std::fs::write(
        &scenario,
        "duration 1\n# the supply\ninput U0 = 12 + log(t)\n",
    )
    .expect("w");
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        &scenario.display().to_string(),
    ]);
    assert_eq!(code(&out), 1);
    let err = stderr(&out);
    assert!(
        err.contains("log.scn:3:7: `U0` is not a finite number at t = 0 s"),
        "{err}"
    );
    assert!(err.contains("defined here"), "{err}");
    let model = dir.join("sinc.bg");
    std::fs::write(
        &model,
        "model sinc\nparam R1 = 10\nparam L1 = 0.1\nSe src = sin(t)/t\nR res = R1\n\
         I ind = L1\nDf i on loop\nsrc -> 1:loop -> res, ind\n",
    )
    .expect("w");
    let out = bgc(&["simulate", &model.display().to_string(), "-e", "duration 1"]);
    assert_eq!(code(&out), 1);
    let err = stderr(&out);
    assert!(
        err.contains("`der(p_ind)` is not a finite number at t = 0 s"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Every duration and step the command line gives is checked as a scenario's are: no
/// infinite, zero, negative or NaN value, no step longer than the duration, no run of more
/// than `MAX_SAMPLES` samples (a mistyped `--duration 1e9` once asked for 8 TB). Each is an
/// error that says what is wrong, before anything is simulated or written.
#[test]
fn simulate_checks_the_duration_and_step_it_is_given() {
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate", "models/dc_motor.bg", "-e", "input U0 = 12"];
        args.extend_from_slice(extra);
        bgc(&args)
    };
    for (extra, says) in [
        (&["--duration", "1e9"][..], "samples"),
        (&["--duration", "1", "--step", "1e-12"][..], "samples"),
        (&["--duration", "inf"][..], "duration"),
        (&["--duration", "NaN"][..], "duration"),
        (&["--duration=-1"][..], "duration"),
        (&["--step", "0"][..], "step"),
        (&["--step=-0.1"][..], "step"),
        (&["--step", "NaN"][..], "step"),
        (
            &["--duration", "1", "--step", "5"][..],
            "longer than the duration",
        ),
    ] {
        let out = run(extra);
        assert_ne!(code(&out), 0, "{extra:?}: {}", stdout(&out));
        assert!(stdout(&out).is_empty(), "{extra:?}: wrote {}", stdout(&out));
        assert!(
            stderr(&out).contains("bgc::usage") && stderr(&out).contains(says),
            "{extra:?}: {}",
            stderr(&out)
        );
    }
    let fine = run(&["--duration", "0.1", "--step", "0.01"]);
    assert_eq!(code(&fine), 0, "{}", stderr(&fine));
}

/// `--plot` draws an SVG with a panel per signal; another extension is refused.
#[test]
fn simulate_plots_svg_only() {
    let dir = scratch("plot");
    let svg = dir.join("run.svg").display().to_string();
    let args = |plot: &str| {
        bgc(&[
            "simulate",
            "models/dc_motor.bg",
            "-e",
            "duration 0.2",
            "-e",
            "input U0 = 12",
            "--plot",
            plot,
        ])
    };
    let out = args(&svg);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let drawn = std::fs::read_to_string(&svg).expect("svg written");
    assert!(
        drawn.starts_with("<svg"),
        "{}",
        &drawn[..80.min(drawn.len())]
    );
    // Each panel is titled with the signal's unit and description from the model.
    for title in [
        "U0 [V]: armature voltage",
        "i: armature current",
        "y1: motor speed",
    ] {
        assert!(drawn.lines().any(|l| l.trim() == title), "panel {title}");
    }
    // A fault's onset is marked in each panel: a grey vertical line.
    let faulty = dir.join("fault.svg").display().to_string();
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "duration 0.2",
        "-e",
        "input U0 = 12",
        "-e",
        "fault Re = 2*Re at 0.1",
        "--plot",
        &faulty,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let drawn = std::fs::read_to_string(&faulty).expect("svg written");
    let marks = drawn
        .split("<polyline")
        .filter(|p| p.contains("opacity=\"0.6\"") && p.contains("stroke=\"#000000\""))
        .filter(|p| {
            let points = p.split("points=\"").nth(1).unwrap_or_default();
            let points = points.split('"').next().unwrap_or_default();
            let xs: Vec<&str> = points
                .split_whitespace()
                .filter_map(|xy| xy.split(',').next())
                .collect();
            xs.len() == 2 && xs[0] == xs[1]
        })
        .count();
    assert_eq!(marks, 3, "one mark per panel (U0, i, y1)");
    let png = dir.join("run.png").display().to_string();
    let refused = args(&png);
    assert_eq!(code(&refused), 2);
    assert!(
        stderr(&refused).contains("SVG only"),
        "{}",
        stderr(&refused)
    );
    // A plot into a directory that does not exist is refused before the run, not after it
    // (where it also lost the samples asked for with -o).
    let csv = dir.join("run.csv").display().to_string();
    let missing = dir
        .join("no_such_dir")
        .join("run.svg")
        .display()
        .to_string();
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "input U0 = 12",
        "--plot",
        &missing,
        "-o",
        &csv,
    ]);
    assert_eq!(code(&out), 2, "{}", stderr(&out));
    assert!(stderr(&out).contains("the directory"), "{}", stderr(&out));
    let out = bgc(&["residuals", "models/dc_motor.bg", &csv, "--plot", &missing]);
    assert_eq!(code(&out), 2, "{}", stderr(&out));
    assert!(stderr(&out).contains("the directory"), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The DC motor simulated under 12 V for `duration` seconds, as CSV.
fn motor_record(duration: &str) -> String {
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "input U0 = 12",
        "--duration",
        duration,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    stdout(&out)
}

/// Writes `text` as `name` in `dir`; its path as an argument.
fn write_in(dir: &std::path::Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("record");
    path.display().to_string()
}

/// A record separated by `;` (what a spreadsheet writes where the decimal mark is a comma) or
/// by tabs gives the residuals of the same record separated by commas; a time column named
/// otherwise, or a signal's column with a typo, is named in the error.
#[test]
fn records_with_other_separators_and_near_miss_columns() {
    let dir = scratch("separators");
    let csv = motor_record("1");
    let write = |name: &str, text: &str| write_in(&dir, name, text);
    let residuals = |path: &str| bgc(&["residuals", "models/dc_motor.bg", path]);
    let comma = residuals(&write("comma.csv", &csv));
    assert_eq!(code(&comma), 0, "{}", stderr(&comma));
    for (name, separator) in [("semicolon.csv", ";"), ("tab.tsv", "\t")] {
        let other = residuals(&write(name, &csv.replace(',', separator)));
        assert_eq!(code(&other), 0, "{name}: {}", stderr(&other));
        assert_eq!(stdout(&other), stdout(&comma), "{name}");
    }
    let time = residuals(&write("time.csv", &csv.replacen("t,", "time,", 1)));
    assert_ne!(code(&time), 0);
    assert!(
        stderr(&time).contains("is `time` the time?"),
        "{}",
        stderr(&time)
    );
    let typo = residuals(&write("typo.csv", &csv.replacen(",y1", ",Y1", 1)));
    assert_ne!(code(&typo), 0);
    assert!(
        stderr(&typo).contains("did you mean `Y1`?"),
        "{}",
        stderr(&typo)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A record's mistakes are told by the file's own line numbers (blank lines counted), a
/// column named twice is refused rather than one of the two used, and a threshold must be
/// a finite number.
#[test]
fn record_lines_duplicate_columns_and_infinite_thresholds() {
    let dir = scratch("record-lines");
    let csv = motor_record("0.5");
    let write = |name: &str, text: &str| write_in(&dir, name, text);
    let residuals = |path: &str, extra: &[&str]| {
        let mut args = vec!["residuals", "models/dc_motor.bg", path];
        args.extend(extra);
        bgc(&args)
    };
    // Two blank lines after the header; the tenth row (line 13 of the file) is not a number.
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    lines.insert(1, String::new());
    lines.insert(2, String::new());
    let mut cells: Vec<String> = lines[12].split(',').map(str::to_string).collect();
    cells[1] = "abc".to_string();
    lines[12] = cells.join(",");
    let blank = residuals(&write("blank.csv", &(lines.join("\n") + "\n")), &[]);
    assert_eq!(code(&blank), 1);
    assert!(
        stderr(&blank).contains("line 13, column `U0`: `abc` is not a finite number"),
        "{}",
        stderr(&blank)
    );
    // A measured signal named twice.
    let twice: String = csv
        .lines()
        .map(|l| format!("{l},{}\n", l.split(',').nth(4).unwrap_or("")))
        .collect();
    let duplicate = residuals(&write("twice.csv", &twice), &[]);
    assert_eq!(code(&duplicate), 1, "{}", stderr(&duplicate));
    assert!(
        stderr(&duplicate).contains("the header names `i` 2 times (columns 5 and 7)"),
        "{}",
        stderr(&duplicate)
    );
    let record = write("record.csv", &csv);
    for level in ["inf", "NaN", "-1"] {
        let given = format!("ARR1={level}");
        let out = residuals(&record, &["--threshold", &given]);
        assert_eq!(code(&out), 2, "{level}");
        assert!(
            stderr(&out).contains("finite non-negative"),
            "{}",
            stderr(&out)
        );
    }
}

/// Times are written as the decimals they are (`0.009`, not `0.009000000000000001`), in
/// simulated records and in residuals alike.
#[test]
fn times_are_written_without_the_bits_sums_of_steps_add() {
    let dir = scratch("times");
    let record = dir.join("run.csv").display().to_string();
    let out = bgc(&[
        "simulate",
        "models/dc_motor.bg",
        "-e",
        "input U0 = 12",
        "--duration",
        "2",
        "-o",
        &record,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let residuals = bgc(&["residuals", "models/dc_motor.bg", &record]);
    assert_eq!(code(&residuals), 0, "{}", stderr(&residuals));
    let simulated = std::fs::read_to_string(&record).expect("record");
    for text in [simulated, stdout(&residuals)] {
        for line in text.lines().skip(1) {
            let t = line.split(',').next().expect("time");
            let decimals = t.split('.').nth(1).map_or(0, str::len);
            assert!(decimals <= 3, "{t} in {line}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A relation that is singular on part of a healthy record (`U − R0 i/x` while `x = 0`, a
/// machine at rest) writes no NaN: those cells are empty, raise no alarm, and standard error
/// says where they are; `--calibrate` on that record sets a finite threshold from the rest.
#[test]
fn a_singular_relation_writes_no_nan_and_calibrates_on_the_rest() {
    let dir = scratch("singular");
    let model = dir.join("singular.bg");
    std::fs::write(
        &model,
        "model singular\nparam R0 = 2\ninput U\ninput x\nSe src = U\nMR r : e = R0*f/x\n\
         Df i on j\nsrc -> 1:j -> r\n",
    )
    .expect("model");
    let mut csv = String::from("t,U,x,i\n");
    for k in 0..1000 {
        let t = f64::from(k) * 1e-3;
        let on = if t >= 0.5 { 1.0 } else { 0.0 };
        csv.push_str(&format!("{t},{},{on},{on}\n", 2.0 * on));
    }
    let record = dir.join("record.csv");
    std::fs::write(&record, csv).expect("record");
    let (model, record) = (model.display().to_string(), record.display().to_string());
    let out = bgc(&["residuals", &model, &record, "--calibrate", &record]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
    let mut empty = 0;
    for line in text.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let threshold: f64 = cells[2].parse().expect("a threshold");
        assert!(threshold.is_finite(), "{line}");
        if cells[1].is_empty() {
            assert_eq!(cells[3], "0", "an empty cell raises no alarm: {line}");
            empty += 1;
        }
    }
    assert!(empty > 400, "{empty}");
    assert!(
        stderr(&out).contains("ARR1 is not a finite number at"),
        "{}",
        stderr(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bgc verify` prints no `inf` or `NaN`: a residual that leaves the numbers under a fault
/// (the Table 3 bench's ARR2 under a fault of y2) is `not finite`.
#[test]
fn verify_prints_no_inf() {
    let out = bgc(&["verify", "models/backlash_bench_table3.bg"]);
    assert_eq!(code(&out), 0, "{}", stdout(&out));
    let table = stdout(&out);
    let words: Vec<&str> = table.split_whitespace().collect();
    assert!(
        !words.iter().any(|w| ["inf", "NaN", "-inf"].contains(w)),
        "{table}"
    );
    assert!(table.contains("not finite"), "{table}");
}

/// A step in a message is the decimal it is: `0.002 s`, not the `0.0020000000000000018 s`
/// that a difference of two sample times holds.
#[test]
fn steps_in_messages_are_decimals() {
    let dir = scratch("steps");
    let record = dir.join("uneven.csv");
    std::fs::write(
        &record,
        "t,U0,i,y1\n0,1,0,0\n0.002,1,0,0\n0.004,1,0,0\n0.0065,1,0,0\n",
    )
    .expect("record");
    let out = bgc(&[
        "residuals",
        "models/dc_motor.bg",
        &record.display().to_string(),
    ]);
    assert_ne!(code(&out), 0);
    assert!(
        stderr(&out).contains(
            "line 5: a step of 0.0025 s where the record's (its median interval) is 0.002 s"
        ),
        "{}",
        stderr(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bgc completions SHELL` prints a completion script that knows the subcommands and options.
#[test]
fn completions_are_printed_for_the_usual_shells() {
    for shell in ["bash", "zsh", "fish", "powershell", "elvish"] {
        let out = bgc(&["completions", shell]);
        assert_eq!(code(&out), 0, "{shell}: {}", stderr(&out));
        let script = stdout(&out);
        for word in ["simulate", "residuals", "verify", "--emit"] {
            assert!(script.contains(word), "{shell}: {word}");
        }
    }
    assert_eq!(code(&bgc(&["completions", "cmd"])), 2);
}

/// The README's residuals example, run as written (its files in a scratch directory): the
/// record it monitors raises no alarm before its fault (the dead zone tripled at 10 s), and
/// alarms after it.
#[test]
fn the_readmes_residuals_example_raises_no_alarm_before_its_fault() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let block = (readme.split("```sh\n"))
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("scenarios/bench_dead_zone.scn -o bench.csv"))
        .expect("the README's residuals example");
    let dir = scratch("readme-residuals");
    let mut last = String::new();
    for line in block.lines().filter(|l| l.starts_with("bgc ")) {
        // What the example writes and reads of its own goes to the scratch directory.
        let args: Vec<String> = (line.split_whitespace().skip(1))
            .map(|a| {
                let own = (a.ends_with(".csv") || a.ends_with(".svg"))
                    && !a.starts_with("models/")
                    && !a.starts_with("scenarios/");
                if own {
                    dir.join(a).display().to_string()
                } else {
                    a.to_string()
                }
            })
            .collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = bgc(&args);
        assert_eq!(code(&out), 0, "{line}: {}", stderr(&out));
        last = stdout(&out);
    }
    let mut lines = last.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let alarms: Vec<usize> = (0..header.len())
        .filter(|&k| header[k].starts_with("alarm_"))
        .collect();
    let (mut early, mut late) = (Vec::new(), 0);
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let t: f64 = cells[0].parse().expect("time");
        let on = alarms.iter().any(|&k| cells[k] == "1");
        // An estimate reads half its window (201 samples of 1 ms) ahead of its instant.
        if on && t < 10.0 - 0.101 {
            early.push(t);
        }
        late += usize::from(on && t > 11.0);
    }
    assert!(early.is_empty(), "alarms before the fault from {early:?}");
    assert!(late > 100, "{late} samples in alarm after the fault");
    // Calibrated instead on the bench driven by a ±4 V sine, the record goes beyond what
    // calibration saw from its start, and its alarms before the fault are said to come after.
    let other = dir.join("sine.csv").display().to_string();
    let model = "models/backlash_bench.bg";
    let out = bgc(&[
        "simulate",
        model,
        "scenarios/paper_section5_healthy.scn",
        "-o",
        &other,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let bench = dir.join("bench.csv").display().to_string();
    let out = bgc(&[
        "residuals",
        model,
        &bench,
        "--calibrate",
        &other,
        "--no-size",
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let said = stderr(&out);
    let beyond = (said.lines())
        .find(|l| l.contains("the record goes beyond what the healthy record covered"))
        .unwrap_or_else(|| panic!("{said}"));
    assert!(beyond.contains("U0 from 0 s"), "{beyond}");
    assert!(
        beyond.contains("comes after it left: it may be the record's"),
        "{beyond}"
    );
    // And per sample: the `beyond` column names the signals outside the sine's ranges (U0
    // at both of the square's levels, the speeds at times), and none of the others.
    let text = stdout(&out);
    let header: Vec<&str> = text.lines().next().expect("a header").split(',').collect();
    let at = header
        .iter()
        .position(|h| *h == "beyond")
        .expect("a beyond column");
    let (mut flagged, mut inside) = (0, 0);
    for line in text.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        for name in cells[at].split(' ').filter(|n| !n.is_empty()) {
            assert!(["U0", "y1", "y2"].contains(&name), "{name}: {line}");
        }
        flagged += usize::from(cells[at].split(' ').any(|n| n == "U0"));
        inside += usize::from(cells[at].is_empty());
    }
    assert!(flagged > 1000, "{flagged} samples with U0 flagged");
    // The first estimate of the record is at rest: what calibration saw too.
    assert!(inside < flagged, "{inside} samples inside");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The examples of the docs that need no file of the user's run as shown: each `sh` block of
/// these pages, in order, in a scratch directory, where every file a command reads that is
/// not the repository's (`models/`, `scenarios/`) was written by an earlier command of the
/// same page (a block that reads the user's own records is left out). Each exits with 0.
/// What they print is checked where a page states it, by the tests of that stage.
#[test]
fn the_docs_self_contained_examples_run_as_shown() {
    for (page, least) in [("docs/simulation.md", 6), ("docs/paper_reproduction.md", 8)] {
        let text = std::fs::read_to_string(root().join(page)).expect("page");
        let dir = scratch(&format!("docs-{}", page.replace(['/', '.'], "-")));
        let mut written: Vec<String> = Vec::new();
        let mut ran = 0;
        for block in (text.split("```sh\n").skip(1)).filter_map(|b| b.split("```").next()) {
            let commands = shell_commands(block);
            // Read only what the page wrote before, in this block or an earlier one.
            let mut known = written.clone();
            let reads_the_users = commands.iter().any(|words| {
                let reads = files(words).any(|(file, output)| !output && !known.contains(&file));
                known.extend(files(words).filter(|f| f.1).map(|f| f.0));
                reads
            });
            if reads_the_users {
                continue;
            }
            for words in &commands {
                let args: Vec<String> = (words.iter().skip(1))
                    .map(|w| match own_file(w) {
                        Some(name) => dir.join(name).display().to_string(),
                        None => w.clone(),
                    })
                    .collect();
                let args: Vec<&str> = args.iter().map(String::as_str).collect();
                let out = bgc(&args);
                assert_eq!(code(&out), 0, "{page}: {words:?}: {}", stderr(&out));
                written.extend(files(words).filter(|f| f.1).map(|f| f.0));
                ran += 1;
            }
        }
        assert!(ran >= least, "{page}: {ran} commands ran");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The `bgc` commands of a shell block: lines joined where they end in `\`, comments and
/// other commands left out, `NAME=value` lines substituted for `$NAME`, words split as a
/// shell does for single and double quotes.
fn shell_commands(block: &str) -> Vec<Vec<String>> {
    let joined = block.replace("\\\n", " ");
    let mut vars: Vec<(String, String)> = Vec::new();
    let mut commands = Vec::new();
    for line in joined.lines() {
        let mut words = shell_words(line);
        if let [only] = words.as_slice() {
            if let Some((name, value)) = only.split_once('=') {
                vars.push((format!("${name}"), value.to_string()));
                continue;
            }
        }
        for w in &mut words {
            for (name, value) in &vars {
                *w = w.replace(name.as_str(), value);
            }
        }
        if words.first().is_some_and(|w| w == "bgc") {
            commands.push(words);
        }
    }
    commands
}

/// A line's words, as a shell splits them (quotes kept together, `#` to the end left out).
fn shell_words(line: &str) -> Vec<String> {
    let (mut words, mut word, mut quote, mut any) = (Vec::new(), String::new(), None, false);
    for ch in line.chars() {
        match (quote, ch) {
            (None, '#') if word.is_empty() => break,
            (None, '\'' | '"') => (quote, any) = (Some(ch), true),
            (Some(q), c) if c == q => quote = None,
            (None, c) if c.is_whitespace() => {
                if any || !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
                any = false;
            }
            (_, c) => word.push(c),
        }
    }
    if any || !word.is_empty() {
        words.push(word);
    }
    words
}

/// The files a command names that are not the repository's, each with whether it writes it
/// (the word after `-o`, `--output` or `--plot`).
fn files(words: &[String]) -> impl Iterator<Item = (String, bool)> + '_ {
    (words.iter().enumerate()).filter_map(|(k, w)| {
        let output = k > 0 && matches!(words[k - 1].as_str(), "-o" | "--output" | "--plot");
        own_file(w).map(|name| (name, output))
    })
}

/// The name in the scratch directory of a file a docs example reads or writes, or `None`
/// for the repository's own (`models/`, `scenarios/`) and for what is not a file.
fn own_file(word: &str) -> Option<String> {
    let files = [".csv", ".parquet", ".params", ".cal", ".svg", ".bg", ".mat"];
    let own = files.iter().any(|e| word.ends_with(e))
        && !word.starts_with("models/")
        && !word.starts_with("scenarios/")
        && !word.starts_with('-');
    own.then(|| word.rsplit('/').next().unwrap_or(word).to_string())
}
