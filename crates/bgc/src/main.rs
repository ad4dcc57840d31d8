//! `bgc`: the bond-graph compiler's command line.
//!
//! Exit codes: 0 when the model is valid and the output written, 1 when the model is invalid,
//! 2 for a usage error (bad arguments, a file that cannot be read or written).

mod calibrate;
mod cli;
mod plot;
mod report;
mod residuals;
mod sensors;
mod simulate;
mod summary;

use std::process::ExitCode;

use clap::Parser as _;

fn main() -> ExitCode {
    let args = cli::Args::parse();
    report::install_hook();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => failure.exit_code(),
    }
}
