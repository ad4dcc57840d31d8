//! `bgc MODEL --emit TARGET`: the model written out (text, JSON, LaTeX, state equations,
//! DOT, Rust residual code).

use std::path::Path;
use std::path::PathBuf;

use bondgraph_core::{Compiled, Derive, ResidualSet};
use clap::ValueEnum;

use crate::io;
use crate::options::{ResidualChoice, SimplifyArgs};
use crate::report::{self, Failure};

/// What `bgc MODEL` takes besides the model.
#[derive(clap::Args, Debug)]
pub(crate) struct EmitArgs {
    /// What to write.
    #[arg(long, value_enum, value_name = "TARGET", default_value = "text")]
    emit: Target,

    /// With `--emit latex`: a whole document that compiles with pdflatex.
    #[arg(long)]
    standalone: bool,

    /// With `--emit json`: the FSM's rows as a `signature` of 0 and 1 per ARR (dense), or as
    /// the names of the ARRs each shows in (sparse); `auto`, dense up to 30 ARRs and sparse
    /// above, keeps the file growing with the model, not with its square.
    #[arg(long, value_enum, value_name = "FORM", default_value = "auto")]
    fsm: FsmArg,

    /// Write the output to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,

    #[command(flatten)]
    choice: ResidualChoice,
    #[command(flatten)]
    values: crate::options::ValuesArg,

    #[command(flatten)]
    simplify: SimplifyArgs,
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
    /// C99 residual code (needs libm only): with `-o FILE.c`, the source and its header
    /// `FILE.h`; to standard output, both as one file. Not written when any error was found.
    C,
    /// An FMI 3.0 co-simulation FMU of the residual generator (`-o FILE.fmu`): its binary
    /// built here by the C compiler (`$CC`, else `cc`; `-O2`, else `$CFLAGS`), its sources
    /// beside it.
    Fmu,
}

/// How the JSON writes the FSM.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FsmArg {
    /// Dense up to 30 ARRs, sparse above (said on standard error).
    Auto,
    /// One 0 or 1 per ARR in each row.
    Dense,
    /// The ARRs each row shows in.
    Sparse,
}

/// The form the JSON's FSM is written in; `auto` going sparse is said.
fn fsm_form(c: &Compiled, asked: FsmArg) -> bondgraph_codegen::json::FsmForm {
    use bondgraph_codegen::json::FsmForm;
    let form = match asked {
        FsmArg::Auto => FsmForm::Auto,
        FsmArg::Dense => FsmForm::Dense,
        FsmArg::Sparse => FsmForm::Sparse,
    };
    let resolved = form.resolve(c);
    if form == FsmForm::Auto && resolved == FsmForm::Sparse {
        report::note(format!(
            "the FSM is written sparse (each row's \"arrs\", not a \"signature\"): {} ARRs are \
             more than {}; --fsm dense writes it dense",
            c.arrs.len(),
            bondgraph_codegen::text::DENSE_FSM_LIMIT
        ));
    }
    resolved
}

/// Writes `model` as `args` ask.
pub(crate) fn run(model: &Path, args: EmitArgs) -> Result<(), Failure> {
    if args.standalone && args.emit != Target::Latex {
        return Err(report::usage("--standalone applies to --emit latex only"));
    }
    if args.fsm != FsmArg::Auto && args.emit != Target::Json {
        return Err(report::usage("--fsm applies to --emit json only"));
    }
    // A drawing needs the ARRs only to fill components by fault class, which
    // `--residuals best|all` asks for.
    let derive = match args.emit {
        Target::Dot if args.choice.set() != ResidualSet::PerSensor => Derive::Everything,
        Target::State | Target::Dot => Derive::StateEquations,
        _ => Derive::Everything,
    };
    let limits = match args.emit {
        Target::Dot => None,
        _ => args.simplify.limits()?,
    };
    let c = io::compile_with(
        model,
        args.values.path(),
        derive,
        limits,
        (args.choice.set(), args.choice.realise()),
    )?;
    let text = match args.emit {
        Target::Text => bondgraph_codegen::text::emit(&c),
        Target::Json => bondgraph_codegen::json::emit_with(&c, fsm_form(&c, args.fsm)),
        Target::Latex => bondgraph_codegen::latex::emit(&c, args.standalone),
        Target::State => bondgraph_codegen::text::state(&c),
        Target::Dot => bondgraph_codegen::dot::emit(&c),
        // Code that misses an ARR or reads a refused one would run and mislead; refused
        // state equations alone leave the ARRs, and their code, as they are.
        Target::Rust if c.residual_code_refused() => return io::succeeded(&c),
        Target::Rust => bondgraph_codegen::rust::emit(&c)
            .map_err(|why| report::refused(format!("{}: cannot write Rust: {why}", c.file_name)))?,
        Target::C if c.residual_code_refused() => return io::succeeded(&c),
        Target::C => return write_c(&c, args.output.as_deref()),
        Target::Fmu if c.residual_code_refused() => return io::succeeded(&c),
        Target::Fmu => {
            crate::fmu::write(&c, args.output.as_deref())?;
            return io::succeeded(&c);
        }
    };
    io::write(args.output.as_deref(), &text)?;
    io::succeeded(&c)
}

/// Writes the model's C code: to `FILE.c` and `FILE.h`, or as one file to standard output.
fn write_c(c: &Compiled, output: Option<&Path>) -> Result<(), Failure> {
    let header = match output {
        Some(path) => header_path(path)?,
        None => PathBuf::from(format!("{}.h", c.name)),
    };
    let header_name = header
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let code = bondgraph_codegen::c::emit(c, &header_name)
        .map_err(|why| report::refused(format!("{}: cannot write C: {why}", c.file_name)))?;
    match output {
        Some(path) => {
            io::write(Some(&header), &code.header)?;
            io::write(Some(path), &code.source)?;
        }
        None => io::write(None, &code.single_file())?,
    }
    io::succeeded(c)
}

/// The header beside a C source `FILE.c`: `FILE.h`. Any other name is refused, since the
/// header would be written over it or beside it under a name the user did not choose.
fn header_path(source: &Path) -> Result<PathBuf, Failure> {
    if source.extension().is_none_or(|e| e != "c") {
        return Err(report::usage(format!(
            "--emit c writes a source and its header: give -o a file name ending in .c (not `{}`)",
            source.display()
        )));
    }
    Ok(source.with_extension("h"))
}
