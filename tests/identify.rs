//! `bgc identify` and parameter files: a known change of the plant's parameters recovered
//! from a simulated record within the intervals bgc states, the file read back by every
//! command, a pair the ARRs hold only as a sum named as such, and bad files refused where
//! they are wrong.

use std::path::Path;

use crate::common::{bgc, code, scratch, stderr, stdout};

/// The estimate and half-width of `name` in a parameter file, if it has an interval.
fn estimate(file: &str, name: &str) -> Option<(f64, f64)> {
    let line = file
        .lines()
        .find(|l| l.starts_with(&format!("{name} = ")))?;
    let value = line.split_whitespace().nth(2)?.parse().ok()?;
    let half = line
        .split("± ")
        .nth(1)?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some((value, half))
}

/// Simulates `model` with the plant's values `plant` (a parameter file) into `dir`.
fn simulate(dir: &Path, model: &str, plant: &str, input: &str, noise: &[&str]) -> String {
    simulate_with(dir, model, plant, input, noise, &[], "record.csv", 3)
}

/// [`simulate`] with more scenario statements, into `name`, with the noise's `seed`.
#[allow(clippy::too_many_arguments)]
fn simulate_with(
    dir: &Path,
    model: &str,
    plant: &str,
    input: &str,
    noise: &[&str],
    more: &[&str],
    name: &str,
    seed: u64,
) -> String {
    let values = dir.join("plant.txt");
    std::fs::write(&values, plant).expect("plant values");
    let record = dir.join(name).display().to_string();
    let mut args = vec![
        "simulate".to_string(),
        model.to_string(),
        "--params".into(),
        values.display().to_string(),
        "-e".into(),
        "duration 60".into(),
        "-e".into(),
        "step 0.001".into(),
        "-e".into(),
        format!("input U0 = {input}"),
        "--seed".into(),
        seed.to_string(),
        "-o".into(),
        record.clone(),
    ];
    for n in noise {
        args.extend(["-e".to_string(), format!("noise {n} 1e-2")]);
    }
    for m in more {
        args.extend(["-e".to_string(), m.to_string()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    record
}

#[test]
fn a_changed_plant_is_recovered_within_its_intervals_and_read_back() {
    let dir = scratch("identify-motor");
    // The motor with its resistance, inertia and friction off the model's by 10-20 %.
    let record = simulate(
        &dir,
        "models/dc_motor.bg",
        "Re = 0.36\nJe = 0.88\nfe = 0.12\n",
        "6 + 12*sin(0.5*t) + 3*sin(7*t)",
        &["i", "y1"],
    );
    let fitted = dir.join("fitted.txt");
    let out = bgc(&[
        "identify",
        "models/dc_motor.bg",
        &record,
        "--window",
        "51",
        "-o",
        &fitted.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let file = std::fs::read_to_string(&fitted).expect("parameter file");
    for (name, truth) in [
        ("Re", 0.36),
        ("L", 0.5),
        ("ke", 0.5),
        ("Je", 0.88),
        ("fe", 0.12),
    ] {
        let (value, half) = estimate(&file, name).unwrap_or_else(|| panic!("{name}: {file}"));
        assert!(
            (value - truth).abs() <= half && half < 0.05 * truth,
            "{name}: {value} ± {half}, true {truth}\n{file}"
        );
    }
    assert!(!file.contains("not determined"), "{file}");
    // Each interval allows for the estimators' bias, read from the fit with the windows
    // halved (51 samples to 25, the integration's 250 to 125), and stays narrow here.
    assert!(
        file.contains("with the windows halved (estimator 25, integration 125 samples)"),
        "{file}"
    );
    // The file is read back: the fitted model's residuals are smaller on the same record.
    let rms = |extra: &[&str]| {
        let mut args = vec!["residuals", "models/dc_motor.bg", &record];
        args.extend(extra);
        let out = bgc(&args);
        assert_eq!(code(&out), 0, "{}", stderr(&out));
        let text = stdout(&out);
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().expect("header").split(',').collect();
        let k = header.iter().position(|h| *h == "ARR1").expect("ARR1");
        let values: Vec<f64> = lines
            .filter_map(|l| l.split(',').nth(k)?.parse().ok())
            .collect();
        (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
    };
    let fitted_path = fitted.display().to_string();
    let (before, after) = (rms(&[]), rms(&["--params", &fitted_path]));
    assert!(after < 0.5 * before, "{before} -> {after}");
    // And the model with its values replaced keeps its comments.
    let model = dir.join("fitted.bg");
    let out = bgc(&[
        "identify",
        "models/dc_motor.bg",
        &record,
        "--window",
        "51",
        "--only",
        "Re",
        "--write-model",
        &model.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = std::fs::read_to_string(&model).expect("model written");
    assert!(text.contains("\"armature resistance\""), "{text}");
    assert!(!text.contains("param Re = 0.3 "), "{text}");
    assert!(text.contains("param L  = 0.5 [H]"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_pair_the_arrs_hold_only_as_a_sum_is_named_as_not_separable() {
    let dir = scratch("identify-sum");
    let model = dir.join("series.bg");
    std::fs::write(
        &model,
        "model series\nparam R1 = 1\nparam R2 = 2\nparam C = 0.5\ninput U0\n\
         Se U = U0\nR r1 = R1\nR r2 = R2\nC c = C\nDf i on loop\nU -> 1:loop -> r1, r2, c\n",
    )
    .expect("model");
    let model = model.display().to_string();
    let record = simulate(&dir, &model, "R1 = 1.2\n", "1 + sin(2*t)", &["i"]);
    let out = bgc(&["identify", &model, &record]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let file = stdout(&out);
    let note = file
        .lines()
        .find(|l| l.starts_with("# not determined apart"))
        .unwrap_or_else(|| panic!("{file}"));
    assert!(
        note.contains("R1")
            && note.contains("R2")
            && !note.contains(" C")
            && note.contains("no record of these sensors separates them"),
        "{note}"
    );
    assert!(file.contains("R1 = ") && file.contains("not determined apart from others"));
    // C is determined on its own, inside its interval although the current's noise is 3 %
    // of it: weighed by plain RMS, the noisy regressor biased it 3.7 % low (errors in
    // variables); weighed by its noise, it is not.
    let (c, half) = estimate(&file, "C").expect("C has an interval");
    assert!((c - 0.5).abs() <= half && half < 0.01, "{file}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_parameter_files_are_refused_where_they_are_wrong() {
    let dir = scratch("identify-bad");
    let values = dir.join("bad.txt");
    for (text, expected) in [
        (
            "Re = 0.3\nke 0.5\n",
            ":2:1: `ke 0.5`: expected `NAME = VALUE`",
        ),
        ("Re = abc\n", ":1:6: `abc`: expected a finite number"),
        (
            "Rr = 0.4\n",
            ":1:1: the model declares no parameter `Rr` (did you mean `Re`?)",
        ),
    ] {
        std::fs::write(&values, text).expect("file");
        let out = bgc(&[
            "models/dc_motor.bg",
            "--params",
            &values.display().to_string(),
        ]);
        assert_eq!(code(&out), 2, "{text}");
        assert!(stderr(&out).contains(expected), "{}", stderr(&out));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The estimator and the integration fixed, for tests of what comes after the calibration's
/// search.
const FIXED: [&str; 6] = [
    "--estimator",
    "savitzky-golay",
    "--window",
    "501",
    "--integration-window",
    "250",
];

#[test]
fn calibration_fits_the_model_first_and_keep_model_keeps_its_values() {
    let dir = scratch("identify-calibrate");
    let record = simulate(
        &dir,
        "models/dc_motor.bg",
        "Re = 0.36\n",
        "6 + 12*sin(0.5*t) + 3*sin(7*t)",
        &["i", "y1"],
    );
    let run = |extra: &[&str]| {
        // The test is of the fit, not of the search after it.
        let mut args = vec![
            "residuals",
            "models/dc_motor.bg",
            &record,
            "--calibrate",
            &record,
        ];
        args.extend(FIXED);
        args.extend(extra);
        let out = bgc(&args);
        assert_eq!(code(&out), 0, "{}", stderr(&out));
        stderr(&out)
    };
    let fitted = run(&[]);
    let note = fitted
        .lines()
        .find(|l| l.contains("the model fitted to it"))
        .unwrap_or_else(|| panic!("{fitted}"));
    assert!(note.contains("Re 0.3 -> 0.36"), "{note}");
    assert!(!note.contains("ke 0.5 ->"), "ke did not move: {note}");
    assert!(!run(&["--keep-model"]).contains("the model fitted to it"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_faults_size_is_estimated_and_its_component_ranked_first() {
    let dir = scratch("identify-size");
    let (model, input, noise) = (
        "models/dc_motor.bg",
        "6 + 12*sin(0.5*t) + 3*sin(7*t)",
        ["i", "y1"],
    );
    let healthy = simulate_with(
        &dir,
        model,
        "Re = 0.3\n",
        input,
        &noise,
        &[],
        "healthy.csv",
        1,
    );
    let faulty = simulate_with(
        &dir,
        model,
        "Re = 0.3\n",
        input,
        &noise,
        &["fault fe = 2*fe at 30"],
        "faulty.csv",
        2,
    );
    let written = dir.join("residuals.csv").display().to_string();
    // The test is of the size, not of the calibration's search.
    let mut args = vec!["residuals", model, &faulty, "--calibrate", &healthy];
    args.extend(FIXED);
    args.extend(["-o", &written]);
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let said = stderr(&out);
    let sizes: Vec<&str> = said
        .lines()
        .skip_while(|l| !l.contains("the fault's size"))
        .skip(1)
        .take_while(|l| l.starts_with("   "))
        .collect();
    let first = sizes.first().unwrap_or_else(|| panic!("{said}"));
    assert!(first.contains("fm: fe = "), "{said}");
    let ratio: f64 = first
        .split("× the model's")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("{first}"));
    assert!((ratio - 2.0).abs() < 0.1, "{first}");
    // The CSV's size columns: empty until the span after the first alarm has been seen, then
    // the friction's estimate.
    let text = std::fs::read_to_string(&written).expect("the residuals");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(
        header[header.len() - 3..],
        ["sized", "size", "size_half_width"]
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let sized: Vec<&Vec<&str>> = rows.iter().filter(|r| !r[r.len() - 3].is_empty()).collect();
    let from: f64 = sized.first().expect("sized rows")[0].parse().expect("time");
    assert!((35.0..36.0).contains(&from), "sized from {from} s");
    assert!(rows
        .iter()
        .all(|r| r[0].parse::<f64>().expect("time") >= from || r[r.len() - 3].is_empty()));
    for r in sized {
        let n = r.len();
        assert_eq!(r[n - 3], "fe");
        let value: f64 = r[n - 2].parse().expect("size");
        assert!((value / 0.2 - 1.0).abs() < 0.05, "{r:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A slide pushed by a force against viscous friction and a constant force, its speed (or
/// its position) measured.
fn slide(dir: &Path, sensor: &str) -> String {
    let model = dir.join("slide.bg");
    std::fs::write(
        &model,
        format!(
            "model slide\nparam M = 2 [kg]\nparam Fv = 4 [N.s/m]\nparam offset = 2 [N]\n\
             input U0 [N]\nSe drive = U0\nSe bias = -offset\nI mass = M\nR visc = Fv\n\
             {sensor} on axis\ndrive -> 1:axis -> mass, visc\nbias -> axis\n"
        ),
    )
    .expect("model");
    model.display().to_string()
}

#[test]
fn an_offset_is_found_across_zero_by_either_criterion() {
    let dir = scratch("identify-offset");
    let model = slide(&dir, "Df v");
    // The plant's constant force is on the other side of zero from the model's.
    let record = simulate(
        &dir,
        &model,
        "M = 2.2\nFv = 4.4\noffset = -1.5\n",
        "3*sin(0.7*t) + 2*sin(2.3*t)",
        &["v"],
    );
    for criterion in ["equation", "simulation"] {
        let out = bgc(&["identify", &model, &record, "--criterion", criterion]);
        assert_eq!(code(&out), 0, "{criterion}: {}", stderr(&out));
        let file = stdout(&out);
        assert!(
            file.contains(&format!("fitted by the {criterion} error")),
            "{file}"
        );
        for (name, truth) in [("M", 2.2), ("Fv", 4.4), ("offset", -1.5)] {
            let (value, half) = estimate(&file, name).unwrap_or_else(|| panic!("{file}"));
            assert!(
                (value - truth).abs() <= half && half < 0.05 * truth.abs(),
                "{criterion}, {name}: {value} ± {half}, true {truth}\n{file}"
            );
        }
        // The fit never ends above where it started.
        let cost = file
            .lines()
            .find_map(|l| l.strip_prefix("# cost "))
            .unwrap_or_else(|| panic!("{file}"));
        let numbers: Vec<f64> = (cost.split([' ', ',']))
            .filter_map(|w| w.parse().ok())
            .collect();
        assert!(numbers.len() >= 3 && numbers[2] <= numbers[1], "{cost}");
    }
    // Validated on another run of the plant: the fit's simulation error is the noise's.
    let other = simulate_with(
        &dir,
        &model,
        "M = 2.2\nFv = 4.4\noffset = -1.5\n",
        "4*sin(0.3*t) + sin(3.1*t)",
        &["v"],
        &[],
        "other.csv",
        11,
    );
    let out = bgc(&[
        "identify",
        &model,
        &record,
        "--criterion",
        "equation",
        "--validate",
        &other,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let file = stdout(&out);
    let line = (file.lines())
        .find(|l| l.starts_with("# validation on") && l.contains("v's simulation error"))
        .unwrap_or_else(|| panic!("{file}"));
    let numbers: Vec<f64> = (line.split([' ', ',']))
        .filter_map(|w| w.parse().ok())
        .collect();
    let (model_error, fitted_error) = (numbers[numbers.len() - 2], numbers[numbers.len() - 1]);
    assert!(
        fitted_error < 0.015 && fitted_error < 0.5 * model_error,
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_position_that_drifts_is_fitted_by_its_equation_error_and_says_why() {
    let dir = scratch("identify-drift");
    let model = slide(&dir, "Dq x");
    let record = simulate(
        &dir,
        &model,
        "M = 2.2\noffset = 1\n",
        "3*sin(0.7*t) + 2*sin(2.3*t)",
        &[],
    );
    let out = bgc(&["identify", &model, &record]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let file = stdout(&out);
    assert!(
        file.contains("fitted by the equation error") && file.contains("does not forget its start"),
        "{file}"
    );
    let (m, half) = estimate(&file, "M").unwrap_or_else(|| panic!("{file}"));
    assert!((m - 2.2).abs() <= half.max(1e-6 * 2.2), "{file}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_short_slow_record_is_fitted_over_a_shorter_integration_window() {
    let dir = scratch("identify-short");
    let model = dir.join("tank.bg");
    std::fs::write(
        &model,
        "model tank\nparam A = 1\nparam kp = 0.05\nparam c = 0.04\ninput u\n\
         Sf pump = kp*u\nC tank = A\nR orifice : f = c*sqrt(e)\nDe h on t\n\
         pump -> 0:t -> tank, orifice\n",
    )
    .expect("model");
    let model = model.display().to_string();
    let plant = dir.join("plant.txt");
    std::fs::write(&plant, "c = 0.046\n").expect("plant");
    let record = dir.join("record.csv").display().to_string();
    // 1,024 samples every 4 s, as the cascaded-tanks benchmark gives them.
    let out = bgc(&[
        "simulate",
        &model,
        "--params",
        &plant.display().to_string(),
        "-e",
        "duration 4092",
        "-e",
        "step 4",
        "-e",
        "input u = 5 + sin(t/300) + 0.8*sin(t/90)",
        "-e",
        "noise h 0.01",
        "-o",
        &record,
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let out = bgc(&[
        "identify",
        &model,
        &record,
        "--fix",
        "A",
        "--criterion",
        "equation",
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(
        stderr(&out).contains("integrated over") && stderr(&out).contains("instead of 250"),
        "{}",
        stderr(&out)
    );
    let (c, half) = estimate(&stdout(&out), "c").unwrap_or_else(|| panic!("{}", stdout(&out)));
    assert!(
        (c - 0.046).abs() <= half && half < 0.002,
        "c = {c} ± {half}"
    );
    // With one level sensor the section, the pump's gain and the orifice scale together: the
    // whole relation scales, its noise with it, and no record can separate them.
    let out = bgc(&["identify", &model, &record, "--criterion", "equation"]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let file = stdout(&out);
    let note = (file.lines())
        .find(|l| l.starts_with("# not determined apart"))
        .unwrap_or_else(|| panic!("{file}"));
    assert!(
        note.contains("A·s, kp·s, c·s") && note.contains("no record of these sensors"),
        "{note}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_model_is_simulated_on_a_records_inputs() {
    let dir = scratch("simulate-record");
    let model = slide(&dir, "Df v");
    let plant = "M = 2.2\nFv = 4.4\noffset = -1.5\n";
    let record = simulate(&dir, &model, plant, "3*sin(0.7*t)", &["v"]);
    let values = dir.join("plant.txt").display().to_string();
    let out = bgc(&["simulate", &model, "--record", &record, "--params", &values]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("t,U0,v\n"),
        "{}",
        &text[..40.min(text.len())]
    );
    // The plant's own values on its own inputs: the error is the sensor's noise (1e-2).
    let note = (stderr(&out).lines())
        .find(|l| l.contains("v's simulation error, RMS"))
        .map(str::to_string)
        .unwrap_or_else(|| panic!("{}", stderr(&out)));
    let rms: f64 = note
        .split("RMS ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("{note}"));
    assert!((0.008..0.012).contains(&rms), "{note}");
    // The model's own values are off the plant's: a larger error.
    let out = bgc(&["simulate", &model, "--record", &record]);
    assert!(
        stderr(&out).contains("simulation error, RMS"),
        "{}",
        stderr(&out)
    );
    assert!(!stderr(&out).contains(&format!("RMS {rms}")));
    // A record of the inputs alone is simulated too, without an error to note.
    let inputs = dir.join("inputs.csv");
    let only: String = (std::fs::read_to_string(&record).expect("record").lines())
        .map(|l| l.split(',').take(2).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(&inputs, only).expect("inputs");
    let out = bgc(&[
        "simulate",
        &model,
        "--record",
        &inputs.display().to_string(),
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(stdout(&out).starts_with("t,U0,v\n") && !stderr(&out).contains("RMS"));
    // A scenario's statements make no sense beside a record.
    let out = bgc(&["simulate", &model, "--record", &record, "-e", "duration 3"]);
    assert_eq!(code(&out), 2, "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The DC motor with its supply's and its two sensors' faults stated (`with`), at the values
/// given (the healthy ones: gains 1, the others 0).
fn motor_with_faults(dir: &Path, values: &str) -> String {
    let text = std::fs::read_to_string(crate::common::root().join("models/dc_motor.bg"))
        .expect("dc_motor")
        .replace("U0 \"supply\"", "U0 with gain = kv \"supply\"")
        .replace(
            "on elec  \"armature current\"",
            "on elec with bias = ib, gain = ig, drift = idr",
        )
        .replace(
            "on shaft \"motor speed\"",
            "on shaft with bias = yb, gain = yg",
        );
    let model = dir.join("motor.bg");
    std::fs::write(&model, format!("{text}{values}")).expect("model");
    model.display().to_string()
}

#[test]
fn a_model_whose_sensors_and_supply_are_off_their_healthy_values_is_consistent() {
    // Read through faults that are present, every relation still vanishes on the model's
    // own trajectories: what the detectors read in simulation and what the ARRs undo agree.
    let dir = scratch("identify-carried-verify");
    let model = motor_with_faults(
        &dir,
        "param kv = 0.9\nparam ib = 0.05\nparam ig = 1.1\nparam idr = 0.01\n\
         param yb = -0.2\nparam yg = 0.95\n",
    );
    let out = bgc(&["verify", &model]);
    assert_eq!(code(&out), 0, "{}{}", stdout(&out), stderr(&out));
    let out = bgc(&[&model]);
    let text = stdout(&out);
    assert!(text.contains("ke * (i - ib - idr * t) / ig"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sensor_and_actuator_faults_are_sized_and_named_as_such() {
    let dir = scratch("identify-carried-size");
    let healthy_values = "param kv = 1\nparam ib = 0\nparam ig = 1\nparam idr = 0\n\
                          param yb = 0\nparam yg = 1\n";
    let model = motor_with_faults(&dir, healthy_values);
    let input = "6 + 12*sin(0.5*t) + 3*sin(7*t)";
    let noise = ["i", "y1"];
    let healthy = simulate_with(&dir, &model, "", input, &noise, &[], "healthy.csv", 1);
    // Calibrated once, as a monitor would be.
    let kept = dir.join("kept.cal").display().to_string();
    let mut args = vec!["residuals", &model, &healthy, "--calibrate", &healthy];
    args.extend(FIXED);
    args.extend(["--save-calibration", &kept, "-o", "/dev/null"]);
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    // Injected as the scenario's signal faults, not through the parameters that size them.
    for (fault, line, truth) in [
        (
            "fault sensor y1 * 1.1 at 30",
            "y1 (sensor gain): yg = ",
            1.1,
        ),
        ("fault sensor i + 0.5 at 30", "i (sensor bias): ib = ", 0.5),
        (
            "fault actuator U0 * 0.8 at 30",
            "U (actuator gain): kv = ",
            0.8,
        ),
    ] {
        let faulty = simulate_with(&dir, &model, "", input, &noise, &[fault], "faulty.csv", 2);
        let out = bgc(&["residuals", &model, &faulty, "--calibration", &kept]);
        assert_eq!(code(&out), 0, "{}", stderr(&out));
        let said = stderr(&out);
        let first = (said.lines())
            .skip_while(|l| !l.contains("the fault's size"))
            .nth(1)
            .unwrap_or_else(|| panic!("{said}"));
        assert!(first.contains(line), "{fault}: {said}");
        let value: f64 = (first.split(line).nth(1))
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{first}"));
        assert!((value / truth - 1.0).abs() < 0.1, "{fault}: {first}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The backlash bench's record with `U0` given by `input` (after the `let`s `before`), the
/// encoders' noise 1e-4, `more` statements, for `duration` seconds, from `seed`.
fn bench(
    dir: &Path,
    (before, input): (&[&str], &str),
    more: &[&str],
    end: u32,
    seed: u64,
) -> String {
    let record = dir.join(format!("bench-{seed}.csv")).display().to_string();
    let duration = format!("duration {end}");
    let input = format!("input U0 = {input}");
    let mut args = vec!["simulate", "models/backlash_bench.bg"];
    let fixed = [
        duration.as_str(),
        "step 0.001",
        "noise y1 1e-4",
        "noise y2 1e-4",
    ];
    let statements: Vec<&str> = (fixed.into_iter().chain(before.iter().copied()))
        .chain([input.as_str()])
        .chain(more.iter().copied())
        .collect();
    args.extend(statements.iter().flat_map(|s| ["-e", s]));
    let seed = seed.to_string();
    args.extend(["--seed", &seed, "-o", &record]);
    let out = bgc(&args);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    record
}

/// The first size bgc reports for `faulty` calibrated on `healthy`: its line.
fn first_size(faulty: &str, healthy: &str) -> String {
    let out = bgc(&[
        "residuals",
        "models/backlash_bench.bg",
        faulty,
        "--calibrate",
        healthy,
        "-o",
        "/dev/null",
    ]);
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    let said = stderr(&out);
    let first = (said.lines())
        .skip_while(|l| !l.contains("the fault's size"))
        .find(|l| l.starts_with("    1  "));
    first.unwrap_or_else(|| panic!("{said}")).to_string()
}

/// The ratio of a size's line to the model's value.
fn ratio(line: &str) -> f64 {
    (line.split("× the model's").next())
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("{line}"))
}

/// A tripled dead zone is sized as such, whichever residuals see it. Under the PD loop, the
/// residuals taken from the span's start explain it; the slope's fit on those integrated
/// from the record's start, at the noise's level before it as after (0.976 from 63,140 on
/// residuals where the width's fit explains 129.8 to 0.914), is no size, and was ranked
/// first as `gamma` 108× for its low cost. Under a square input the twist rests past the
/// dead zone, the span's residuals see nothing, and only those from the record's start
/// (the law itself) size it.
#[test]
fn a_dead_zone_is_sized_whether_the_spans_residuals_see_it_or_only_the_records() {
    let dir = scratch("identify-dead-zone");
    let fault = ["fault j0 = 3*j0 at 15"];
    let pd = (
        &["let ref = 10*(1 - exp(-t))"][..],
        "1.25*(ref - int(y2)) + 0.5*(der(ref) - y2)",
    );
    let healthy = bench(&dir, pd, &[], 25, 11);
    let faulty = bench(&dir, pd, &fault, 25, 12);
    let first = first_size(&faulty, &healthy);
    assert!(first.contains("w: j0 = "), "{first}");
    assert!((ratio(&first) - 3.0).abs() < 0.1, "{first}");
    let square = (&[][..], "6 + 4*tanh(20*sin(0.5*t))");
    let healthy = bench(&dir, square, &[], 80, 13);
    let faulty = bench(&dir, square, &["fault j0 = 3*j0 at 40"], 80, 14);
    let first = first_size(&faulty, &healthy);
    assert!(first.contains("w: j0 = "), "{first}");
    assert!((ratio(&first) - 3.0).abs() < 0.1, "{first}");
    let _ = std::fs::remove_dir_all(&dir);
}
