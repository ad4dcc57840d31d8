//! `bgc identify`: the model's parameters fitted to healthy records, written as a parameter
//! file that every command reads (`--params`), with the interval of each estimate and what
//! the records do not determine as comments.

use std::fmt::Write as _;
use std::path::PathBuf;

use bondgraph_core::{Compiled, Derive, Options, ParameterValues, ResidualSet};
use bondgraph_interpreter::{
    identify_by, simulation_error, Chosen, Combination, Criteria, Criterion, Determined, Estimator,
    Fit, Identification, Integration, Record, Settings,
};

use crate::io;
use crate::options::{ResidualChoice, ValuesArg};
use crate::record::{Data, Layout};
use crate::report::{self, Failure};

/// What `bgc identify` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct IdentifyArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// Healthy records of the plant (CSV, Parquet, a MAT-file, TDMS or MDF 4, as
    /// `bgc residuals` reads them), fitted together.
    #[arg(value_name = "RECORD", required = true)]
    records: Vec<PathBuf>,
    /// The records' time column, where it is not `t`.
    #[arg(long, value_name = "NAME", default_value = "t")]
    time: String,
    /// The records' column of a signal named otherwise in the model, as `SIGNAL=COLUMN`;
    /// repeat for more.
    #[arg(long = "column", value_name = "SIGNAL=COLUMN")]
    columns: Vec<String>,
    /// Fit only these parameters (repeat); the others keep their values.
    #[arg(long = "only", value_name = "NAME")]
    only: Vec<String>,
    /// Keep these parameters at their values (repeat).
    #[arg(long = "fix", value_name = "NAME")]
    fix: Vec<String>,
    /// Keep the parameters the model gives a `+- x%` within it (by default an estimate
    /// outside it is only flagged: a plant further from its data sheet than stated is worth
    /// knowing about).
    #[arg(long)]
    bounded: bool,
    /// Samples in the Savitzky–Golay window of the estimates (odd).
    #[arg(long, value_name = "N", default_value_t = 11)]
    window: usize,
    /// Samples the integrated residuals are integrated over (default 250, or less on a
    /// record too short for it: see docs/identification.md).
    #[arg(long, value_name = "N")]
    integration_window: Option<usize>,
    #[command(flatten)]
    choice: ResidualChoice,
    #[command(flatten)]
    values: ValuesArg,
    /// Which error the fit minimises: the ARRs' residuals (`equation`), each sensor against
    /// a copy of the model the recorded inputs drive from rest (`simulation`, the output
    /// error), or whichever of the two predicts the held-out last 30 % of the records
    /// better, fitted again on the whole (`evidence`).
    #[arg(long, value_enum, value_name = "ERROR", default_value = "evidence")]
    criterion: CriterionArg,
    /// Records to validate the fit on (the plant's other runs, not fitted): the simulation
    /// error of each sensor, with the model's values and with the fit, in the file's header.
    #[arg(long = "validate", value_name = "RECORD")]
    validate: Vec<PathBuf>,
    /// Write the parameter file to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also write the model with its values replaced by the estimates (comments and layout
    /// kept) to FILE.
    #[arg(long, value_name = "FILE")]
    write_model: Option<PathBuf>,
}

/// `--criterion`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum CriterionArg {
    /// The ARRs' residuals (equation error).
    Equation,
    /// Each sensor against a copy of the model the recorded inputs drive (output error).
    Simulation,
    /// Whichever predicts a held-out tail of the records better.
    Evidence,
}

impl CriterionArg {
    fn criterion(self) -> Criterion {
        match self {
            CriterionArg::Equation => Criterion::Equation,
            CriterionArg::Simulation => Criterion::Simulation,
            CriterionArg::Evidence => Criterion::Evidence,
        }
    }
}

/// The model compiled for its simulated residuals (the output error), without printing its
/// diagnostics again: `None` where it has none.
fn simulated_model(args: &IdentifyArgs, c: &Compiled) -> Option<Compiled> {
    if args.criterion == CriterionArg::Equation && args.validate.is_empty() {
        return None;
    }
    let (_, bytes) = io::read(&args.model).ok()?;
    let text = String::from_utf8(bytes).ok()?;
    let text = match args.values.path() {
        Some(path) => io::read_values(path).ok()?.apply(&text).ok()?,
        None => text,
    };
    let options = Options {
        derive: Derive::Everything,
        simplify: Some(bondgraph_core::Limits::default()),
        residuals: ResidualSet::Simulated,
        realise: args.choice.realise(),
    };
    let out = bondgraph_core::compile(&text, &c.file_name, &options).ok()?;
    (!out.compiled.arrs.is_empty()).then_some(out.compiled)
}

/// Runs `bgc identify`.
pub(crate) fn run(args: IdentifyArgs) -> Result<(), Failure> {
    let c = io::compile_with(
        &args.model,
        args.values.path(),
        Derive::Everything,
        Some(bondgraph_core::Limits::default()),
        (args.choice.set(), args.choice.realise()),
    )?;
    io::succeeded(&c)?;
    if c.residual_code_refused() {
        return Err(report::refused(format!(
            "{}: no ARRs to fit the parameters to",
            c.file_name
        )));
    }
    let program = c.program();
    let names: Vec<String> = program.raw.values().map(|r| r.name.clone()).collect();
    let layout = Layout::new(&names, &args.time, &args.columns)?;
    let records = (args.records.iter())
        .map(|path| Data::load(path, &layout, args.window))
        .collect::<Result<Vec<Data>, Failure>>()?;
    let step = records[0].step;
    let degree = program.top_order().max(3);
    let settings = Settings {
        fit: Fit {
            step,
            estimator: Estimator::SavitzkyGolay {
                window: args.window,
                degree,
            },
            integration: vec![
                Integration::Window(integration_window(&args, &records));
                c.arrs.len()
            ],
        },
        free: free(&c, &args.only, &args.fix)?,
        bounded: args.bounded,
        span: None,
    };
    check_steps(&args.records, &records)?;
    let views: Vec<Record<'_>> = (records.iter())
        .map(|d| Record {
            time: &d.time,
            raw: d.columns.iter().map(Vec::as_slice).collect(),
            state: None,
        })
        .collect();
    let start: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let simulated = simulated_model(&args, &c);
    let simulated_program = simulated.as_ref().map(Compiled::program);
    let criteria = Criteria {
        equation: (&c, &program),
        simulation: simulated.as_ref().zip(simulated_program.as_ref()),
    };
    let (found, chosen) = identify_by(
        &criteria,
        &start,
        &views,
        &settings,
        args.criterion.criterion(),
    )
    .map_err(|e| report::refused(format!("{}: {e}", c.file_name)))?;
    if let (Some(why), CriterionArg::Simulation) = (&chosen.fallback, args.criterion) {
        report::warn(format!(
            "{}: fitted by the equation error instead of the simulation error: {why}",
            c.file_name
        ));
    }
    let validation = validate(&args, &criteria, &start, &found, &settings)?;
    for l in &found.lost {
        report::warn(format!(
            "{}: the fit ran `{}` to {} (from {}), out of all proportion: held at its start, \
             the others fitted without it",
            c.file_name,
            l.name,
            significant(l.towards),
            significant(start[l.parameter])
        ));
    }
    let sources: Vec<String> = args
        .records
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    io::write(
        args.output.as_deref(),
        &parameter_file(&c, &found, &sources, &chosen, &validation),
    )?;
    if let Some(path) = &args.write_model {
        write_model(&args, &c, &found, path)?;
    }
    Ok(())
}

/// The integration window: as given, else the default where the shortest record holds it,
/// else the largest it holds (with a note).
fn integration_window(args: &IdentifyArgs, records: &[Data]) -> usize {
    if let Some(n) = args.integration_window {
        return n;
    }
    let rows = records.iter().map(|d| d.time.len()).min().unwrap_or(0);
    let (n, shrunk) = bondgraph_interpreter::integration_window_for(rows, args.window);
    if shrunk {
        report::note(format!(
            "the records are short ({rows} samples): integrated residuals are integrated over \
             {n} samples instead of {} (--integration-window sets it)",
            bondgraph::Reference::DEFAULT_WINDOW
        ));
    }
    n
}

/// Each validation record's simulation error per sensor, with the model's values and with
/// the fit (its name, the sensors, and the two errors).
struct Validation {
    record: String,
    sensors: Vec<String>,
    model: Vec<f64>,
    fitted: Vec<f64>,
}

/// The simulation error of the model's values and of the fit on each `--validate` record.
fn validate(
    args: &IdentifyArgs,
    criteria: &Criteria<'_>,
    start: &[f64],
    found: &Identification,
    settings: &Settings,
) -> Result<Vec<Validation>, Failure> {
    if args.validate.is_empty() {
        return Ok(Vec::new());
    }
    let Some((sc, sp)) = criteria.simulation else {
        return Err(report::refused(format!(
            "--validate: {}",
            criteria.simulation_missing().unwrap_or_default()
        )));
    };
    let names: Vec<String> = sp.raw.values().map(|r| r.name.clone()).collect();
    let layout = Layout::new(&names, &args.time, &args.columns)?;
    let mut out = Vec::new();
    for path in &args.validate {
        let data = Data::load(path, &layout, args.window)?;
        let record = [Record {
            time: &data.time,
            raw: data.columns.iter().map(Vec::as_slice).collect(),
            state: None,
        }];
        let mut settings = settings.clone();
        settings.fit.step = data.step;
        let error = |values: &[f64]| simulation_error(sc, sp, values, &record, &[0], &settings);
        out.push(Validation {
            record: path.display().to_string(),
            sensors: sensors(sc),
            model: error(start),
            fitted: error(&found.values),
        });
    }
    Ok(out)
}

/// The sensor each simulated residual compares, by name.
fn sensors(c: &Compiled) -> Vec<String> {
    (c.arrs.iter())
        .map(|a| {
            a.sensor
                .map_or_else(|| a.name.clone(), |s| c.sensors[s].name.clone())
        })
        .collect()
}

/// The parameters to fit, by their place: `only` (or every one), less `fix`.
fn free(c: &Compiled, only: &[String], fix: &[String]) -> Result<Vec<usize>, Failure> {
    let free = bondgraph_interpreter::choose_free(c, only, fix)
        .map_err(|e| report::usage(format!("--only/--fix: {e}")))?;
    if free.is_empty() {
        return Err(report::usage("no parameter left to fit (--only and --fix)"));
    }
    Ok(free)
}

/// Every record at the first's step: the estimators are built for one.
fn check_steps(paths: &[PathBuf], records: &[Data]) -> Result<(), Failure> {
    let step = records[0].step;
    for (path, data) in paths.iter().zip(records) {
        if (data.step - step).abs() > bondgraph_interpreter::STEP_TOLERANCE * step {
            return Err(report::refused(format!(
                "{}: its step ({} s) is not the first record's ({} s)",
                path.display(),
                io::seconds(data.step),
                io::seconds(step)
            )));
        }
    }
    Ok(())
}

/// The parameter file: a line per parameter with its interval and the model's value as a
/// comment, and what the records do not determine in the header.
fn parameter_file(
    c: &Compiled,
    found: &Identification,
    sources: &[String],
    chosen: &Chosen,
    validation: &[Validation],
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# {}: parameters identified by bgc identify from {}",
        c.name,
        sources.join(", ")
    );
    let _ = writeln!(out, "# {}", criterion_line(chosen));
    for v in validation {
        for (k, sensor) in v.sensors.iter().enumerate() {
            let _ = writeln!(
                out,
                "# validation on {}: {sensor}'s simulation error RMS {} with the model's \
                 values, {} fitted",
                v.record,
                significant(v.model[k]),
                significant(v.fitted[k])
            );
        }
    }
    let _ = writeln!(
        out,
        "# {} residual samples in {} batches; 95 % intervals (Student, batch means); \
         condition number {:.3e}; {} after {} iterations",
        found.samples,
        found.batches,
        found.condition,
        match found.stop.0 {
            bondgraph_interpreter::Stop::Converged => "converged",
            bondgraph_interpreter::Stop::Iterations => "stopped at the iteration limit",
        },
        found.stop.1
    );
    if let Some(line) = reach_line(c, found) {
        let _ = writeln!(out, "# {line}");
    }
    if found.jumps > 0 && found.left_out > 0 {
        let _ = writeln!(
            out,
            "# {} jumps of a signal (a step input's edges): the {} estimates within the \
             estimators' and integration's reach of one are left out",
            found.jumps, found.left_out
        );
    } else if found.jumps > 0 {
        let _ = writeln!(
            out,
            "# {} fast changes of a signal, throughout the records: not a step input's \
             edges but the signal itself (a closed loop's drive), fitted through",
            found.jumps
        );
    }
    let _ = writeln!(
        out,
        "# cost (residuals over the noise they carry, mean square: 1 is the noise) {} with \
         the model's values, {} fitted",
        significant(found.cost.0),
        significant(found.cost.1)
    );
    for (arr, (before, after)) in c.arrs.iter().zip(&found.rms) {
        let _ = writeln!(
            out,
            "# {}: RMS {} with the model's values, {} fitted",
            arr.name,
            significant(*before),
            significant(*after)
        );
    }
    for combination in &found.undetermined {
        let _ = writeln!(out, "# {}", undetermined(c, found, combination));
    }
    for e in &found.estimates {
        let value = to_interval(e.value, e.half_width);
        let note = match e.determined {
            Determined::Yes | Determined::Weakly => {
                let change = if e.start == 0.0 {
                    String::new()
                } else {
                    format!(" ({:+.2} %)", 100.0 * (e.value / e.start - 1.0))
                };
                let weak = if e.determined == Determined::Weakly {
                    "; weakly determined: the interval is wider than the value"
                } else {
                    ""
                };
                let bound = if e.at_bound {
                    "; at the model's +- bound (--bounded): the records pull it further".into()
                } else {
                    outside(c, e)
                };
                format!(
                    "± {} (95 %), model {}{change}{weak}{bound}",
                    significant(e.half_width),
                    significant(e.start)
                )
            }
            Determined::No if ran_away(e) => format!(
                "not determined: the fit drove it to {} of the model's {}, where no residual \
                 depends on it; fix it (--fix {}) or fit records that excite it",
                significant(e.value / e.start),
                significant(e.start),
                e.name
            ),
            Determined::No => {
                "not determined apart from others (see above): moved only along what the \
                 records determine"
                    .into()
            }
            Determined::Unread => "no residual reads it: model's value".into(),
            Determined::Held => match &c
                .parameters
                .values()
                .nth(e.parameter)
                .and_then(|p| p.carried.clone())
            {
                Some(fault) => format!(
                    "held at its healthy value: the {} (`with`), fitted only if named (--only {})",
                    fault.describe(),
                    e.name
                ),
                None => "held (--only/--fix)".into(),
            },
            Determined::Lost => lost(found, e),
        };
        let _ = writeln!(out, "{} = {value}  # {note}", e.name);
    }
    out
}

/// Which error was minimised, and why.
fn criterion_line(chosen: &Chosen) -> String {
    let what = match chosen.criterion {
        Criterion::Simulation => {
            "fitted by the simulation error (each sensor against a copy of the model the \
             recorded inputs drive from rest)"
        }
        _ => "fitted by the equation error (the ARRs' residuals)",
    };
    let rms = |e: &[f64]| {
        (e.iter().map(|&x| significant(x)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match (&chosen.evidence, &chosen.fallback) {
        (Some(e), _) => format!(
            "{what}: chosen by evidence: fitted on the first {:.0} % of the records, the \
             simulation error on the rest was {} (RMS per sensor) by the equation error's fit \
             and {} by the simulation error's",
            100.0 * (1.0 - e.held_out),
            rms(&e.equation),
            rms(&e.simulation)
        ),
        (None, Some(why)) => format!("{what}: {why}"),
        (None, None) => format!("{what}: as asked (--criterion)"),
    }
}

/// Why a parameter the fit ran away with is held at its start.
fn lost(found: &Identification, e: &bondgraph_interpreter::Estimate) -> String {
    let towards = (found.lost.iter())
        .find(|l| l.parameter == e.parameter)
        .map_or(f64::NAN, |l| l.towards);
    let whither = if towards.is_finite() {
        format!("to {}", significant(towards))
    } else {
        "to no number".into()
    };
    format!(
        "held at its start: the fit ran it {whither}, out of all proportion to its start, \
         where these records do not hold it; the others were fitted without it (fix it with \
         --fix {}, or fit records that excite it)",
        e.name
    )
}

/// Whether the fit drove a parameter by more than a factor of a million from its model
/// value: its scaling then no longer moves any residual, and it is lost rather than
/// determined in combination.
fn ran_away(e: &bondgraph_interpreter::Estimate) -> bool {
    e.start != 0.0 && (e.value / e.start).abs().ln().abs() > 1e6f64.ln()
}

/// A flag for an estimate outside the model's `+- x%` by more than its interval.
fn outside(c: &Compiled, e: &bondgraph_interpreter::Estimate) -> String {
    let Some(p) = c.parameters.values().nth(e.parameter) else {
        return String::new();
    };
    match p.uncertainty {
        Some(half) if (e.value - e.start).abs() > half + e.half_width => format!(
            "; outside the model's +- {} by more than its interval",
            significant(half)
        ),
        _ => String::new(),
    }
}

/// What a combination the records do not determine means, in the parameters' names.
fn undetermined(c: &Compiled, found: &Identification, combination: &Combination) -> String {
    let names: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    // A parameter at 0 moves by a shift (`offset + 0.5·s`, to first order); one that moves
    // by a shift of its start's size moves, to first order, by a factor: its exponent is the
    // coordinate's times its start's size over its value.
    let additive = |k: usize| {
        found
            .estimates
            .get(k)
            .is_some_and(|e| e.signed && e.start == 0.0)
    };
    let exponent = |k: usize, x: f64| match found.estimates.get(k) {
        // d ln(value) = |start| du / value, where the combination is found (the fit).
        Some(e) if e.signed && e.value != 0.0 => x * e.start.abs() / e.value,
        _ => x,
    };
    // Exponents to two decimals: those that round to 0 barely take part.
    let moves: Vec<String> = (combination.scalings.iter())
        .map(|&(k, x)| (k, (exponent(k, x) * 100.0).round() / 100.0))
        .filter(|&(_, e)| e != 0.0)
        .map(|(k, e)| match e {
            e if additive(k) => format!("{} + {}·s", names[k], significant(e)),
            1.0 => format!("{}·s", names[k]),
            -1.0 => format!("{}/s", names[k]),
            e if e > 0.0 => format!("{}·s^{e}", names[k]),
            e => format!("{}/s^{}", names[k], -e),
        })
        .collect();
    let why = if combination.structural {
        "the ARRs hold them only so: no record of these sensors separates them"
    } else {
        "these records do not excite what separates them: a record with other inputs (another \
         frequency, amplitude or level) may"
    };
    format!(
        "not determined apart: {} (any s) leave every residual as it is; {why}",
        moves.join(", ")
    )
}

/// `x` to 6 significant digits, as the language reads numbers back (in exponent form when
/// it is very small or large).
/// What halving the estimators' windows moved, by which the intervals were widened.
fn reach_line(c: &Compiled, found: &Identification) -> Option<String> {
    let reach = found.reach.as_ref()?;
    let moves: Vec<String> = (reach.values.iter())
        .filter(|(k, _)| {
            matches!(
                found.estimates[*k].determined,
                Determined::Yes | Determined::Weakly
            )
        })
        .map(|&(k, v)| {
            let name = c.parameters.values().nth(k).map_or("", |p| p.name.as_str());
            let moved = v - found.values[k];
            let sign = if moved >= 0.0 { "+" } else { "" };
            format!("{name} {sign}{}", significant(moved))
        })
        .collect();
    if moves.is_empty() {
        return None;
    }
    let (window, integration) = reach.windows;
    let integration = if integration > 0 {
        format!(", integration {integration}")
    } else {
        String::new()
    };
    Some(format!(
        "the estimators' bias: with the windows halved (estimator {window}{integration} \
         samples) the fit moves {}; each interval is widened by twice that",
        moves.join(", ")
    ))
}

pub(crate) fn significant(x: f64) -> String {
    if !x.is_finite() {
        return "inf".into();
    }
    let text = format!("{x:.5e}");
    let value: f64 = text.parse().unwrap_or(x);
    if value != 0.0 && !(1e-4..1e6).contains(&value.abs()) {
        let short = format!("{value:e}");
        return short;
    }
    format!("{value}")
}

/// An estimate to a hundredth of its interval's half-width (at least 6 significant digits):
/// the file's value must not be further from the estimate than its interval allows.
fn to_interval(x: f64, half_width: f64) -> String {
    if !(half_width.is_finite() && half_width > 0.0) || x == 0.0 {
        return significant(x);
    }
    let digits = (x.abs().log10().floor() - (half_width / 100.0).log10().floor()).max(5.0);
    // At most what an f64 holds.
    let digits = digits.min(16.0) as usize;
    let text = format!("{x:.digits$e}");
    let value: f64 = text.parse().unwrap_or(x);
    if !(1e-4..1e6).contains(&value.abs()) {
        return text;
    }
    format!("{value}")
}

/// The model with the estimates in place of its values.
fn write_model(
    args: &IdentifyArgs,
    c: &Compiled,
    found: &Identification,
    path: &std::path::Path,
) -> Result<(), Failure> {
    let (_, bytes) = io::read(&args.model)?;
    let text = String::from_utf8(bytes).map_err(|_| report::usage("the model is not UTF-8"))?;
    let values = ParameterValues::from_pairs(
        (c.parameters.values().zip(&found.values)).map(|(p, &v)| (p.name.clone(), v)),
    );
    let text = values
        .apply(&text)
        .map_err(|e| report::usage(format!("{}: {e}", args.model.display())))?;
    io::write(Some(path), &text)
}
