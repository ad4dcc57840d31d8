//! `bgc verify`: the model's ARRs and FSM checked numerically on its own trajectories.

use std::path::PathBuf;

use bondgraph_core::Derive;
use bondgraph_sim::VerifyOptions;
use indicatif::{ProgressBar, ProgressStyle};

use crate::io;
use crate::options::{ResidualChoice, SimplifyArgs};
use crate::report::{self, Failure};
use crate::summary;

/// What `bgc verify` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct VerifyArgs {
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
    #[command(flatten)]
    choice: ResidualChoice,
    #[command(flatten)]
    values: crate::options::ValuesArg,
    /// Write the table to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    #[command(flatten)]
    simplify: SimplifyArgs,
}

/// Runs `bgc verify`: exit 1 when any check fails.
pub(crate) fn run(args: VerifyArgs) -> Result<(), Failure> {
    let options = VerifyOptions {
        input_scale: args.input_scale,
        state_scale: args.state_scale,
        steps: args.steps,
        step: args.step,
        ..VerifyOptions::default()
    };
    options.check().map_err(report::usage)?;
    let c = io::compile_with(
        &args.model,
        args.values.path(),
        Derive::Everything,
        args.simplify.limits()?,
        (args.choice.set(), args.choice.realise()),
    )?;
    io::succeeded(&c)?;
    // One simulation per fault: minutes on a large model, so the bar says how far it is (on
    // a terminal; indicatif draws nothing otherwise).
    let bar = ProgressBar::new(c.components.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "verifying {bar:40} {pos}/{len} components ({eta} left) {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut scale = options.state_scale;
    let v = bondgraph_sim::verify_reporting(&c, &options, &mut |p| {
        if p.scale != scale {
            scale = p.scale;
            bar.set_message(format!("(initial states scaled to {scale:e})"));
        }
        bar.set_position(p.components as u64);
    });
    bar.finish_and_clear();
    let v = v.map_err(|e| report::refused(format!("{}: cannot verify: {e}", c.file_name)))?;
    io::write(args.output.as_deref(), &summary::verification(&c, &v))?;
    if v.passed() {
        Ok(())
    } else {
        Err(report::refused(format!(
            "{}: verification failed",
            c.file_name
        )))
    }
}
