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
    let (inputs, states) = (c.inputs.len(), c.states.len());
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
