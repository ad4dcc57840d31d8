//! `bgc causality`: the causality of a model in both modes.

use std::path::PathBuf;

use bondgraph_core::Derive;

use crate::io;
use crate::report::Failure;

/// What `bgc causality` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct CausalityArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// Write the report to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

/// Runs `bgc causality`.
pub(crate) fn run(args: CausalityArgs) -> Result<(), Failure> {
    let c = io::compile(&args.model, Derive::Everything, None)?;
    io::write(
        args.output.as_deref(),
        &bondgraph_codegen::text::causality(&c),
    )?;
    io::succeeded(&c)
}
