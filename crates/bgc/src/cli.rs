//! Arguments and what each command does with them.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use std::time::Duration;

use bondgraph_core::{
    Compiled, Derive, Limits, Options, Realise, ResidualSet, Stop, Unsimplified, VerifyOptions,
};
use clap::{Parser, Subcommand, ValueEnum};

use crate::report;
use crate::summary;

/// bgc — a bond-graph compiler for model-based fault detection.
///
/// Reads a `.bg` model (a bond graph with its sensors) and checks it or writes it out.
#[derive(Parser, Debug)]
#[command(name = "bgc", version, about, long_about = None)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct Args {
    #[command(subcommand)]
    command: Option<Command>,

    /// The model to read (a `.bg` file, or `-` for standard input).
    #[arg(value_name = "MODEL", required = true)]
    model: Option<PathBuf>,

    /// What to write.
    #[arg(long, value_enum, value_name = "TARGET", default_value = "text")]
    emit: Target,

    /// With `--emit latex`: a whole document that compiles with pdflatex.
    #[arg(long)]
    standalone: bool,

    /// With `--emit json`: the FSM's rows as a `signature` of 0 and 1 per ARR (dense), or as
    /// the names of the ARRs each shows in (sparse, for large models).
    #[arg(long, value_enum, value_name = "FORM", default_value = "dense")]
    fsm: FsmArg,

    /// Write the output to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,

    /// Which residuals to derive: one ARR per detector (as the reference paper does), the
    /// smallest set found that tells apart every fault class bgc can reach (`best`), or
    /// every candidate with a signature of its own (`all`).
    #[arg(long, value_enum, value_name = "SET", default_value = "per-sensor")]
    residuals: ResidualsArg,

    /// How residual generators evaluate each ARR: integrated once where that lowers the
    /// derivatives it reads (`lowest`), or as written (`direct`).
    #[arg(long, value_enum, value_name = "HOW", default_value = "lowest")]
    realise: RealiseArg,

    #[command(flatten)]
    simplify: SimplifyArgs,
}

/// `--realise`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum RealiseArg {
    /// Each ARR whose derivatives enter linearly with constant coefficients as the change of
    /// its integral, reading one order of derivative fewer; the others as written.
    Lowest,
    /// Every ARR as written.
    Direct,
}

impl RealiseArg {
    pub(crate) fn realise(self) -> Realise {
        match self {
            RealiseArg::Lowest => Realise::Lowest,
            RealiseArg::Direct => Realise::Direct,
        }
    }
}

/// `--residuals`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum ResidualsArg {
    /// One ARR per detector.
    PerSensor,
    /// The smallest set found that reaches the most isolability the candidates allow.
    Best,
    /// Every candidate with a signature of its own.
    All,
}

impl ResidualsArg {
    pub(crate) fn set(self) -> ResidualSet {
        match self {
            ResidualsArg::PerSensor => ResidualSet::PerSensor,
            ResidualsArg::Best => ResidualSet::Best,
            ResidualsArg::All => ResidualSet::All,
        }
    }
}

/// How expressions are written: the e-graph search for their shortest form.
#[derive(clap::Args, Debug)]
struct SimplifyArgs {
    /// Show expressions in canonical form (expanded sums of products), without the e-graph.
    #[arg(long)]
    canonical: bool,

    /// Most e-nodes the simplifier may build for one expression; larger expressions are
    /// shown in canonical form.
    #[arg(long, value_name = "N", default_value_t = Limits::default().nodes)]
    egg_nodes: usize,

    /// Most rounds of rule application in one e-graph.
    #[arg(long, value_name = "N", default_value_t = Limits::default().iterations)]
    egg_iterations: usize,

    /// Most e-graphs grown one after the other for one expression, each from the best form
    /// of the one before.
    #[arg(long, value_name = "N", default_value_t = Limits::default().rounds)]
    egg_rounds: usize,

    /// Most e-nodes for all the expressions of the model together; expressions met after it
    /// is spent are shown in canonical form.
    #[arg(long, value_name = "N", default_value_t = Limits::default().budget)]
    egg_budget: usize,

    /// Wall-clock limit for one expression's search, in seconds. Reaching it stops bgc with
    /// an error: the clock never decides what is printed, only counts do.
    #[arg(long, value_name = "SECONDS", default_value_t = Limits::default().time.as_secs_f64())]
    egg_seconds: f64,
}

impl SimplifyArgs {
    /// The limits asked for, or why they make no sense.
    fn limits(&self) -> Result<Option<Limits>, Failure> {
        if self.canonical {
            return Ok(None);
        }
        let time = Duration::try_from_secs_f64(self.egg_seconds).map_err(|_| {
            eprintln!(
                "error: --egg-seconds wants a non-negative number of seconds, not `{}`",
                self.egg_seconds
            );
            Failure::Usage
        })?;
        Ok(Some(Limits {
            nodes: self.egg_nodes,
            iterations: self.egg_iterations,
            rounds: self.egg_rounds,
            budget: self.egg_budget,
            time,
        }))
    }
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check a model and print what it holds: counts of elements, bonds, junctions, detectors,
    /// and its parameters.
    Check {
        /// The model to check.
        #[arg(value_name = "MODEL")]
        model: PathBuf,
        /// Write the summary to FILE instead of standard output.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Check the model's ARRs and FSM numerically: every residual on simulated trajectories
    /// of the model (exact derivatives along its state equations), every FSM entry with the
    /// component faulted in the plant only. Prints a table; exits 1 on any failure.
    Verify {
        /// The model.
        #[arg(value_name = "MODEL")]
        model: PathBuf,
        /// Amplitude of the test inputs, u_k(t) = A (1 + 0.5 sin(w_k t + k)).
        #[arg(long, value_name = "A", default_value_t = VerifyOptions::default().input_scale)]
        input_scale: f64,
        /// Typical size of the initial states.
        #[arg(long, value_name = "X", default_value_t = VerifyOptions::default().state_scale)]
        state_scale: f64,
        /// RK4 steps per run.
        #[arg(long, value_name = "N", default_value_t = VerifyOptions::default().steps)]
        steps: usize,
        /// The step, in seconds.
        #[arg(long, value_name = "H", default_value_t = VerifyOptions::default().step)]
        step: f64,
        /// Which residuals to derive and check (see `bgc --help`).
        #[arg(long, value_enum, value_name = "SET", default_value = "per-sensor")]
        residuals: ResidualsArg,
        /// How the residuals are realised (see `bgc --help`); an integrated one is checked
        /// as its rate plus its level's derivative.
        #[arg(long, value_enum, value_name = "HOW", default_value = "lowest")]
        realise: RealiseArg,
        /// Write the table to FILE instead of standard output.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Simulate a model under a scenario (inputs, closed loops, faults, noise) and write the
    /// samples as CSV: time, inputs as commanded, states, measured signals as reported.
    Simulate(crate::simulate::SimulateArgs),
    /// Evaluate the ARRs over recorded samples (CSV: `t` and one column per input and
    /// measured signal) and write residuals, thresholds, alarms and candidate components as
    /// CSV.
    Residuals(crate::residuals::ResidualArgs),
    /// Propose the fewest detectors to add so that components become detectable, or as
    /// isolable as detectors can make them (judged structurally).
    Sensors(crate::sensors::SensorArgs),
    /// Print a completion script for a shell (`bgc completions bash > /etc/bash_completion.d/bgc`,
    /// `bgc completions zsh > ~/.zfunc/_bgc`, `bgc completions fish > ~/.config/fish/completions/bgc.fish`).
    Completions {
        /// The shell.
        #[arg(value_enum, value_name = "SHELL")]
        shell: clap_complete::Shell,
    },
    /// Print the causality of a model in both modes: storage causality, what sets each
    /// junction, conflicts and algebraic loops.
    Causality {
        /// The model.
        #[arg(value_name = "MODEL")]
        model: PathBuf,
        /// Write the report to FILE instead of standard output.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
}

/// The output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Target {
    /// Causality, state equations, ARRs and the FSM as a readable summary.
    Text,
    /// The same as JSON (the schema is in the README).
    Json,
    /// ARRs in an `align` environment and the FSM as a `tabular`.
    Latex,
    /// The state equations and detector outputs only.
    State,
    /// Graphviz DOT of the bond graph with causal strokes (`dot -Tsvg` draws it).
    Dot,
    /// Rust residual code (needs the `bondgraph` crate); not written when any error was found.
    Rust,
}

/// How the JSON writes the FSM.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FsmArg {
    /// One 0 or 1 per ARR in each row.
    Dense,
    /// The ARRs each row shows in.
    Sparse,
}

/// Why bgc stops without success.
pub enum Failure {
    /// The model has errors; they were reported.
    Invalid,
    /// Arguments or files were wrong; the reason was printed.
    Usage,
}

impl Failure {
    /// The process exit code for this failure.
    pub fn exit_code(&self) -> ExitCode {
        match self {
            Failure::Invalid => ExitCode::from(1),
            Failure::Usage => ExitCode::from(2),
        }
    }
}

/// Runs the command the arguments describe.
pub fn run(args: Args) -> Result<(), Failure> {
    match (args.command, args.model) {
        (Some(Command::Check { model, output }), _) => {
            let c = compile(&model, Derive::Nothing, None)?;
            write(output.as_deref(), &summary::check(&c))?;
            succeeded(&c)
        }
        (Some(Command::Simulate(simulate)), _) => crate::simulate::run(simulate),
        (Some(Command::Residuals(residuals)), _) => crate::residuals::run(residuals),
        (Some(Command::Sensors(sensors)), _) => crate::sensors::run(sensors),
        (Some(Command::Completions { shell }), _) => {
            use clap::CommandFactory as _;
            let mut out = Vec::new();
            clap_complete::generate(shell, &mut Args::command(), "bgc", &mut out);
            write(None, &String::from_utf8_lossy(&out))
        }
        (Some(Command::Causality { model, output }), _) => {
            let c = compile(&model, Derive::Everything, None)?;
            write(output.as_deref(), &bondgraph_codegen::text::causality(&c))?;
            succeeded(&c)
        }
        (
            Some(Command::Verify {
                model,
                input_scale,
                state_scale,
                steps,
                step,
                residuals,
                realise,
                output,
            }),
            _,
        ) => {
            let c = compile_with(
                &model,
                Derive::Everything,
                args.simplify.limits()?,
                (residuals.set(), realise.realise()),
            )?;
            succeeded(&c)?;
            let options = VerifyOptions {
                input_scale,
                state_scale,
                steps,
                step,
                ..VerifyOptions::default()
            };
            let v = bondgraph_core::verify(&c, &options).map_err(|e| {
                eprintln!("error: {}: cannot verify: {e}", c.file_name);
                Failure::Invalid
            })?;
            write(output.as_deref(), &crate::summary::verification(&c, &v))?;
            if v.passed() {
                Ok(())
            } else {
                eprintln!("error: {}: verification failed", c.file_name);
                Err(Failure::Invalid)
            }
        }
        (None, Some(model)) => {
            if args.standalone && args.emit != Target::Latex {
                eprintln!("error: --standalone applies to --emit latex only");
                return Err(Failure::Usage);
            }
            if args.fsm == FsmArg::Sparse && args.emit != Target::Json {
                eprintln!("error: --fsm applies to --emit json only");
                return Err(Failure::Usage);
            }
            // A drawing needs the ARRs only to fill components by fault class, which
            // `--residuals best|all` asks for.
            let derive = match args.emit {
                Target::Dot if args.residuals.set() != bondgraph_core::ResidualSet::PerSensor => {
                    Derive::Everything
                }
                Target::State | Target::Dot => Derive::StateEquations,
                _ => Derive::Everything,
            };
            let limits = match args.emit {
                Target::Dot => None,
                _ => args.simplify.limits()?,
            };
            let c = compile_with(
                &model,
                derive,
                limits,
                (args.residuals.set(), args.realise.realise()),
            )?;
            let text = match args.emit {
                Target::Text => bondgraph_codegen::text::emit(&c),
                Target::Json => bondgraph_codegen::json::emit_with(
                    &c,
                    match args.fsm {
                        FsmArg::Dense => bondgraph_codegen::json::FsmForm::Dense,
                        FsmArg::Sparse => bondgraph_codegen::json::FsmForm::Sparse,
                    },
                ),
                Target::Latex => bondgraph_codegen::latex::emit(&c, args.standalone),
                Target::State => bondgraph_codegen::text::state(&c),
                Target::Dot => bondgraph_codegen::dot::emit(&c),
                // Code that misses an ARR or reads a refused one would run and mislead; refused
                // state equations alone leave the ARRs, and their code, as they are.
                Target::Rust if c.residual_code_refused() => return succeeded(&c),
                Target::Rust => bondgraph_codegen::rust::emit(&c),
            };
            write(args.output.as_deref(), &text)?;
            succeeded(&c)
        }
        // clap requires MODEL when there is no subcommand.
        (None, None) => Err(Failure::Usage),
    }
}

/// Exit 1 when some output was refused: its errors were reported.
fn succeeded(c: &Compiled) -> Result<(), Failure> {
    if c.has_errors() {
        Err(Failure::Invalid)
    } else {
        Ok(())
    }
}

/// Names what the simplifier skipped and why; what the budget left out, in one line.
fn warn_unsimplified(skipped: &[Unsimplified]) {
    let over_budget: Vec<&str> = skipped
        .iter()
        .filter(|s| s.stop == Stop::Budget)
        .map(|s| s.what.as_str())
        .collect();
    for s in skipped.iter().filter(|s| s.stop != Stop::Budget) {
        eprintln!(
            "warning: {} is shown in canonical form: it is larger than --egg-nodes",
            s.what
        );
    }
    if let [first, ..] = over_budget.as_slice() {
        eprintln!(
            "warning: {} expressions, from {first} on, are shown in canonical form: \
             --egg-budget was spent on the ones before",
            over_budget.len()
        );
    }
}

/// Reads a model (a file, or standard input for `-`) and compiles it, reporting every
/// diagnostic on standard error.
pub(crate) fn compile(
    path: &Path,
    derive: Derive,
    simplify: Option<Limits>,
) -> Result<Compiled, Failure> {
    compile_with(
        path,
        derive,
        simplify,
        (ResidualSet::PerSensor, Realise::default()),
    )
}

/// [`compile`] with the residual set asked for and how to realise them.
pub(crate) fn compile_with(
    path: &Path,
    derive: Derive,
    simplify: Option<Limits>,
    (residuals, realise): (ResidualSet, Realise),
) -> Result<Compiled, Failure> {
    let (name, bytes) = read(path)?;
    let options = Options {
        derive,
        simplify,
        residuals,
        realise,
    };
    let out = report::compile(&name, bytes, &options).ok_or(Failure::Invalid)?;
    warn_unsimplified(&out.unsimplified);
    Ok(out.compiled)
}

pub(crate) fn read(path: &Path) -> Result<(String, Vec<u8>), Failure> {
    use std::io::Read as _;
    if path == Path::new("-") {
        let mut bytes = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut bytes)
            .map_err(|e| {
                eprintln!("error: cannot read standard input: {e}");
                Failure::Usage
            })?;
        return Ok(("<stdin>".to_string(), bytes));
    }
    let bytes = std::fs::read(path).map_err(|e| {
        eprintln!("error: cannot read `{}`: {e}", path.display());
        Failure::Usage
    })?;
    Ok((path.display().to_string(), bytes))
}

/// Appends `v` in the shortest form that reads back to the same `f64` (`1e-7`, `0.25`,
/// `3.0`): the CSV writers print millions of numbers, and this is a few times faster than
/// `Display`.
pub(crate) fn push_number(out: &mut String, v: f64) {
    out.push_str(ryu::Buffer::new().format(v));
}

/// A duration for a message, to 9 significant digits: a step of `0.002`, not of
/// `0.0020000000000000018`, which is what a difference of two sample times holds.
pub(crate) fn seconds(x: f64) -> String {
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    ryu::Buffer::new().format(rounded).to_string()
}

/// Time `t` on a record of step `step`, rounded to a millionth of the step's decade: what
/// sums of steps add in the last bits (`9.908000000000001`, `0.005999999999999999`) is not
/// written. Dividing by a power of ten, exact up to 1e22, gives the double nearest the
/// decimal, which prints as it.
pub(crate) fn tidy_time(t: f64, step: f64) -> f64 {
    if !(t.is_finite() && step.is_finite() && step > 0.0) {
        return t;
    }
    let digits = (6.0 - step.log10().floor()).clamp(0.0, 22.0);
    let scale = 10f64.powi(digits as i32);
    let scaled = (t * scale).round();
    // Past 2^53 the scaled time is no longer exact: leave it as it is.
    if scaled.abs() < 9.0e15 {
        scaled / scale
    } else {
        t
    }
}

/// Writes `text` to a file beside `path`, then renames it: a reader never sees half a file,
/// and a failed write leaves what was there.
fn atomically(path: &Path, text: &str) -> std::io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".bgc-part");
    let part = path.with_file_name(name);
    std::fs::write(&part, text)?;
    std::fs::rename(&part, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&part);
    })
}

pub(crate) fn write(path: Option<&Path>, text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let result = match path {
        Some(path) => atomically(path, text).map_err(|e| (path.display().to_string(), e)),
        None => std::io::stdout()
            .lock()
            .write_all(text.as_bytes())
            .map_err(|e| ("standard output".to_string(), e)),
    };
    result.map_err(|(place, e)| {
        eprintln!("error: cannot write {place}: {e}");
        Failure::Usage
    })
}
