//! `bgc check`: whether a model is valid, and what it holds.

use std::path::PathBuf;

use bondgraph_core::Derive;

use crate::io;
use crate::report::Failure;
use crate::summary;

/// What `bgc check` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct CheckArgs {
    /// The model to check.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// Write the summary to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

/// Runs `bgc check`.
pub(crate) fn run(args: CheckArgs) -> Result<(), Failure> {
    let c = io::compile(&args.model, Derive::Nothing, None)?;
    io::write(args.output.as_deref(), &summary::check(&c))?;
    io::succeeded(&c)
}
