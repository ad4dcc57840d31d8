//! `bgc`: the bond-graph compiler's command line.
//!
//! Exit codes: 0 when the model is valid and the output written, 1 when the model is invalid,
//! 2 for a usage error (bad arguments, a file that cannot be read or written).
//!
//! One module per command (`check`, `verify`, `simulate`, `residuals`, `identify`, `sensors`,
//! `causality`, `completions`, and `emit` when none is given); `io` reads and writes for all
//! of them, `report` says everything they have to say on standard error.

mod args;
mod causality;
mod check;
mod completions;
mod emit;
mod fmu;
mod identify;
mod io;
mod options;
mod output;
mod parquet_record;
mod plot;
mod record;
mod report;
mod residuals;
mod sensors;
mod simulate;
mod size;
mod summary;
mod verify;
mod zip;

use std::process::ExitCode;

use clap::{CommandFactory as _, Parser as _};

use args::{Args, Command};
use report::Failure;

fn main() -> ExitCode {
    let args = Args::parse();
    report::install_hook();
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => failure.exit_code(),
    }
}

/// Runs the command the arguments name.
fn run(args: Args) -> Result<(), Failure> {
    match (args.command, args.model) {
        (Some(Command::Check(a)), _) => check::run(a),
        (Some(Command::Verify(a)), _) => verify::run(a),
        (Some(Command::Simulate(a)), _) => simulate::run(a),
        (Some(Command::Residuals(a)), _) => residuals::run(a),
        (Some(Command::Identify(a)), _) => identify::run(a),
        (Some(Command::Sensors(a)), _) => sensors::run(a),
        (Some(Command::Causality(a)), _) => causality::run(a),
        (Some(Command::Completions { shell }), _) => completions::run(shell, Args::command()),
        (None, Some(model)) => emit::run(&model, args.emit),
        // clap requires MODEL when there is no subcommand.
        (None, None) => Err(Failure::Usage),
    }
}
