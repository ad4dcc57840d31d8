//! `bgc simulate`: a model under a scenario, integrated and written as CSV.

use std::path::PathBuf;

use bondgraph_core::{Compiled, Derive, Realise, ResidualSet};
use bondgraph_sim::{parse_scenario, Simulation, Solver, Trajectory};
use indicatif::{ProgressBar, ProgressStyle};

use crate::io;
use crate::report::{self, Failure};

/// What `bgc simulate` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct SimulateArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// The scenario file (see docs/simulation.md); statements given with `-e` follow it.
    #[arg(value_name = "SCENARIO")]
    scenario: Option<PathBuf>,
    /// A scenario statement, e.g. `-e 'input U0 = 12'` or `-e 'fault Re = 1.5*Re at 5'`;
    /// repeat for more.
    #[arg(short = 'e', long = "set", value_name = "STATEMENT")]
    statements: Vec<String>,
    /// How long to simulate, in seconds (overrides the scenario).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// The step of the written samples, in seconds (overrides the scenario).
    #[arg(long, value_name = "SECONDS")]
    step: Option<f64>,
    /// The noise's seed (overrides the scenario).
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// The integration method (overrides the scenario).
    #[arg(long, value_enum, value_name = "METHOD")]
    solver: Option<SolverArg>,
    #[command(flatten)]
    values: crate::options::ValuesArg,
    /// Write the CSV to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also draw the inputs and measured signals, one panel each, into FILE (SVG).
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Drive the model by a record's inputs instead of a scenario (CSV, Parquet, a MAT-file,
    /// TDMS or MDF 4): the sensors' outputs of a copy of the model run from rest on the
    /// inputs as sampled (linear between samples), at the record's instants; where the
    /// record also holds a sensor, its simulation error is noted.
    #[arg(long, value_name = "RECORD", conflicts_with_all = ["scenario", "statements", "duration", "step", "seed", "solver", "plot"])]
    record: Option<PathBuf>,
    /// The record's time column, where it is not `t` (with --record).
    #[arg(long, value_name = "NAME", default_value = "t", requires = "record")]
    time: String,
    /// The record's column of a signal named otherwise in the model, as `SIGNAL=COLUMN`
    /// (with --record); repeat for more.
    #[arg(long = "column", value_name = "SIGNAL=COLUMN", requires = "record")]
    columns: Vec<String>,
}

/// The integration methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum SolverArg {
    /// Dormand–Prince 5(4), explicit: for models that are not stiff.
    Dopri5,
    /// ESDIRK 5(4), implicit: for stiff models.
    Implicit,
    /// Dormand–Prince, then the implicit method if the model proves stiff.
    Auto,
}

/// Runs `bgc simulate`.
pub(crate) fn run(args: SimulateArgs) -> Result<(), Failure> {
    if let Some(record) = &args.record {
        return on_record(&args, record);
    }
    if let Some(path) = &args.plot {
        crate::plot::check_path(path).map_err(report::usage)?;
    }
    let c = io::compile_with(
        &args.model,
        args.values.path(),
        Derive::StateEquations,
        None,
        (ResidualSet::PerSensor, Realise::default()),
    )?;
    let (name, text) = scenario_text(&args)?;
    let (scenario, diagnostics) = parse_scenario(&text);
    report::print(&name, &text, &diagnostics);
    let mut scenario = scenario.ok_or(Failure::Invalid)?;
    override_settings(&mut scenario, &args);
    // The scenario's own settings were checked as it was read; the command line's are now.
    let wrong = scenario.check_settings();
    let mut failure = None;
    for w in wrong {
        failure = Some(report::usage(format!(
            "{name}: {w} (with --duration and --step as given)"
        )));
    }
    if let Some(failure) = failure {
        return Err(failure);
    }
    let simulation = Simulation::new(&c, &scenario).map_err(|d| {
        report::print(&name, &text, &d);
        Failure::Invalid
    })?;
    let bar = progress(scenario.duration / scenario.output_step);
    let trajectory = simulation
        .run(|done| {
            if let Some(bar) = &bar {
                bar.set_position((done * 1000.0) as u64);
            }
        })
        .map_err(|e| stopped(&simulation, &e, (&name, &text), &c.file_name))?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    // The samples first: a plot that cannot be drawn leaves them written.
    io::write(args.output.as_deref(), &csv(&trajectory))?;
    if let Some(path) = &args.plot {
        plot(path, &trajectory, &c, &scenario.fault_onsets())?;
    }
    Ok(())
}

/// `bgc simulate --record`: the model's outputs on a record's inputs, as CSV (time, inputs,
/// each sensor's simulated value), with each recorded sensor's simulation error noted.
fn on_record(args: &SimulateArgs, path: &std::path::Path) -> Result<(), Failure> {
    let c = io::compile_with(
        &args.model,
        args.values.path(),
        Derive::Everything,
        Some(bondgraph_core::Limits::default()),
        (ResidualSet::Simulated, Realise::default()),
    )?;
    io::succeeded(&c)?;
    if c.arrs.is_empty() {
        return Err(report::refused(format!(
            "{}: a copy of the model cannot run on recorded inputs (its state equations are \
             implicit, incomplete or read an input's derivative, it has no detector, or its \
             detectors times its equations pass 2e7)",
            c.file_name
        )));
    }
    let program = c.program();
    let (data, measured) = record_columns(args, &program, path)?;
    let raw: Vec<&[f64]> = data.iter().map(Vec::as_slice).collect();
    let record = bondgraph_interpreter::Record {
        time: &measured.time,
        raw,
        state: None,
    };
    let values: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let outputs =
        bondgraph_interpreter::simulate_record(&c, &program, &values, &record, measured.step)
            .map_err(|e| report::refused(format!("{}: {e}", c.file_name)))?;
    let diverged = (outputs.iter())
        .filter_map(|o| o.iter().position(|v| !v.is_finite()))
        .min();
    if let Some(k) = diverged {
        return Err(report::refused(format!(
            "{}: the copy of the model is not a number from t = {} s of {} on (it diverged \
             there): nothing is written",
            c.file_name,
            measured.time[k.min(measured.time.len() - 1)],
            path.display()
        )));
    }
    note_errors(&c, &program, &record, &outputs, &measured.present, path);
    io::write(
        args.output.as_deref(),
        &record_csv(&c, &program, &record, &outputs, measured.step),
    )
}

/// A record's time, step, and which of the program's raw signals it holds.
struct Measured {
    time: Vec<f64>,
    step: f64,
    present: Vec<bool>,
}

/// The program's raw columns from the record at `path`: the inputs (required), and each
/// sensor where the record has it (zeros where not: the copy reads none).
fn record_columns(
    args: &SimulateArgs,
    program: &bondgraph_core::program::Program,
    path: &std::path::Path,
) -> Result<(Vec<Vec<f64>>, Measured), Failure> {
    use bondgraph_core::Signal;
    let names: Vec<String> = program.raw.values().map(|r| r.name.clone()).collect();
    let layout = crate::record::Layout::new(&names, &args.time, &args.columns)?;
    let is_input: Vec<bool> = (program.raw.values())
        .map(|r| matches!(r.signal, Signal::Input(_)))
        .collect();
    let (_, bytes) = io::read(path)?;
    let name = path.display().to_string();
    let loaded = |data: crate::record::Data| {
        if let Some(note) = data.jitter_note() {
            report::note(format!("{name}: {note}"));
        }
        data
    };
    // Every column at once where the record has them all; else the inputs alone.
    if let Ok(data) = crate::record::Data::read(bytes.clone(), &layout, 1) {
        let data = loaded(data);
        let present = vec![true; names.len()];
        let measured = Measured {
            time: data.time,
            step: data.step,
            present,
        };
        return Ok((data.columns, measured));
    }
    let inputs = crate::record::Layout {
        time: layout.time.clone(),
        signals: (layout.signals.iter().zip(&is_input))
            .filter(|(_, &i)| i)
            .map(|(s, _)| s.clone())
            .collect(),
    };
    let data = crate::record::Data::read(bytes, &inputs, 1)
        .map_err(|e| report::refused(format!("{name}: {e}")))?;
    let data = loaded(data);
    let mut given = data.columns.into_iter();
    let columns = (is_input.iter())
        .map(|&i| {
            if i {
                given.next().unwrap_or_default()
            } else {
                vec![0.0; data.time.len()]
            }
        })
        .collect();
    let measured = Measured {
        time: data.time,
        step: data.step,
        present: is_input,
    };
    Ok((columns, measured))
}

/// Notes each recorded sensor's simulation error (RMS).
fn note_errors(
    c: &Compiled,
    program: &bondgraph_core::program::Program,
    record: &bondgraph_interpreter::Record<'_>,
    outputs: &[Vec<f64>],
    present: &[bool],
    path: &std::path::Path,
) {
    for (arr, simulated) in c.arrs.iter().zip(outputs) {
        let Some(sensor) = arr.sensor.map(|s| c.sensors[s].name.as_str()) else {
            continue;
        };
        let Some(j) = program.raw.values().position(|r| r.name == sensor) else {
            continue;
        };
        if !present[j] {
            continue;
        }
        let sum: f64 = (record.raw[j].iter().zip(simulated))
            .map(|(y, s)| (y - s) * (y - s))
            .sum();
        let rms = (sum / simulated.len().max(1) as f64).sqrt();
        report::note(format!(
            "{}: {sensor}'s simulation error, RMS {} (the copy from rest on the recorded inputs)",
            path.display(),
            crate::identify::significant(rms)
        ));
    }
}

/// The CSV of a simulation on a record: time, the inputs as recorded, each sensor simulated.
fn record_csv(
    c: &Compiled,
    program: &bondgraph_core::program::Program,
    record: &bondgraph_interpreter::Record<'_>,
    outputs: &[Vec<f64>],
    step: f64,
) -> String {
    use bondgraph_core::Signal;
    let inputs: Vec<(String, &[f64])> = (program.raw.values().zip(&record.raw))
        .filter(|(r, _)| matches!(r.signal, Signal::Input(_)))
        .map(|(r, column)| (r.name.clone(), *column))
        .collect();
    let sensors: Vec<String> = (c.arrs.iter())
        .map(|a| {
            a.sensor
                .map_or_else(|| a.name.clone(), |s| c.sensors[s].name.clone())
        })
        .collect();
    let mut out = String::new();
    let header: Vec<&str> = std::iter::once("t")
        .chain(inputs.iter().map(|(n, _)| n.as_str()))
        .chain(sensors.iter().map(String::as_str))
        .collect();
    out.push_str(&header.join(","));
    out.push('\n');
    for (k, &t) in record.time.iter().enumerate() {
        io::push_number(&mut out, io::tidy_time(t, step));
        for (_, column) in &inputs {
            out.push(',');
            io::push_number(&mut out, column[k]);
        }
        for simulated in outputs {
            out.push(',');
            io::push_number(&mut out, simulated.get(k).copied().unwrap_or(f64::NAN));
        }
        out.push('\n');
    }
    out
}

/// Reports why the run stopped: at the scenario's line when its cause is written there (an
/// input whose expression is not a number), else against the model.
fn stopped(
    simulation: &Simulation,
    e: &bondgraph_sim::SimulationError,
    (name, text): (&str, &str),
    model: &str,
) -> Failure {
    use bondgraph_core::diagnostic::{Code, Diagnostic, Diagnostics};
    let Some(span) = simulation.locate(e) else {
        return report::refused(format!("{model}: {e}"));
    };
    let mut d = Diagnostics::default();
    d.push(
        Diagnostic::error(Code::BadValue, span, e.to_string())
            .with_label("defined here")
            .with_help("its expression has no finite value there: a division by zero, log or sqrt outside their domain, an overflow"),
    );
    report::print(name, text, &d);
    Failure::Invalid
}

/// The recorded signals (not the states), one panel each, titled with their unit and
/// description from the model.
fn plot(
    path: &std::path::Path,
    t: &Trajectory,
    c: &Compiled,
    faults: &[f64],
) -> Result<(), Failure> {
    let (inputs, states) = (c.inputs.len(), c.model_states());
    let shown: Vec<usize> = (1..=inputs)
        .chain(1 + inputs + states..t.columns.len())
        .collect();
    let titles: Vec<String> = c
        .inputs
        .iter()
        .map(|(_, u)| title(&u.name, u.unit.as_deref(), u.description.as_deref()))
        .chain(
            c.sensors
                .iter()
                .map(|(_, s)| title(&s.name, None, s.description.as_deref())),
        )
        .collect();
    let panels: Vec<crate::plot::Panel<'_>> = shown
        .iter()
        .zip(&titles)
        .map(|(&k, title)| crate::plot::Panel {
            name: title,
            values: &t.values[k],
            threshold: None,
            alarm: None,
            marks: faults,
        })
        .collect();
    crate::plot::draw(path, &t.values[0], &panels).map_err(report::usage)
}

/// `U0 [V]: armature voltage`.
fn title(name: &str, unit: Option<&str>, description: Option<&str>) -> String {
    let mut out = name.to_string();
    if let Some(unit) = unit {
        out.push_str(&format!(" [{unit}]"));
    }
    if let Some(description) = description {
        out.push_str(&format!(": {description}"));
    }
    out
}

/// The scenario file's text and the `-e` statements after it, under one name for reports.
fn scenario_text(args: &SimulateArgs) -> Result<(String, String), Failure> {
    let (mut name, mut text) = match &args.scenario {
        Some(path) => {
            let (name, bytes) = io::read(path)?;
            let text = String::from_utf8(bytes)
                .map_err(|_| report::usage(format!("`{name}` is not UTF-8 text")))?;
            (name, text)
        }
        None => ("<command line>".to_string(), String::new()),
    };
    if !args.statements.is_empty() {
        if args.scenario.is_some() {
            name.push_str(" + -e");
        }
        if !text.is_empty() && !text.ends_with('\n') {
            text.push('\n');
        }
        for s in &args.statements {
            text.push_str(s);
            text.push('\n');
        }
    }
    Ok((name, text))
}

fn override_settings(s: &mut bondgraph_sim::Scenario, args: &SimulateArgs) {
    if let Some(d) = args.duration {
        s.duration = d;
    }
    if let Some(h) = args.step {
        s.output_step = h;
    }
    if let Some(seed) = args.seed {
        s.seed = seed;
    }
    if let Some(solver) = args.solver {
        s.solver = match solver {
            SolverArg::Dopri5 => Solver::DormandPrince,
            SolverArg::Implicit => Solver::Implicit,
            SolverArg::Auto => Solver::Auto,
        };
    }
}

/// A progress bar on standard error for a long run (it draws nothing when standard error is
/// not a terminal).
fn progress(samples: f64) -> Option<ProgressBar> {
    (samples > 1e6).then(|| {
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template("simulating {bar:40} {percent:>3}% ({eta} left)")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    })
}

/// The samples as CSV: a header of column names, then one row per sample. Numbers are
/// written in the shortest form that reads back to the same `f64`.
pub(crate) fn csv(t: &Trajectory) -> String {
    let rows = t.values.first().map_or(0, Vec::len);
    let mut out = String::with_capacity(rows * t.columns.len() * 20);
    out.push_str(&t.columns.join(","));
    out.push('\n');
    let step = t
        .values
        .first()
        .and_then(|time| Some(time.get(1)? - time.first()?))
        .unwrap_or(f64::INFINITY);
    for k in 0..rows {
        for (i, column) in t.values.iter().enumerate() {
            if i > 0 {
                out.push(',');
                io::push_number(&mut out, column[k]);
            } else {
                io::push_number(&mut out, io::tidy_time(column[k], step));
            }
        }
        out.push('\n');
    }
    out
}
