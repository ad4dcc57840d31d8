//! `bgc sensors`: where to add detectors so that components become detectable or as
//! isolable as detectors can make them.

use std::fmt::Write as _;
use std::path::PathBuf;

use bondgraph_core::{Derive, Goal, NamedClasses, Placement};
use clap::ValueEnum;

use crate::io;
use crate::report::{self, Failure};

/// `bgc sensors`' arguments.
#[derive(clap::Args, Debug)]
pub(crate) struct SensorArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// What the added detectors must achieve: every target detectable, or every target told
    /// apart from every component that some placement of detectors could tell it from.
    #[arg(long, value_enum, value_name = "GOAL", default_value = "isolable")]
    goal: GoalArg,
    /// A component the goal is about (repeat for more); all components when none is given.
    #[arg(long = "component", value_name = "NAME")]
    components: Vec<String>,
    /// Write the proposals to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

/// `--goal`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum GoalArg {
    /// Each target shows in some residual.
    Detectable,
    /// Each target is as isolable as detectors can make it.
    Isolable,
}

/// Runs `bgc sensors`.
pub(crate) fn run(args: SensorArgs) -> Result<(), Failure> {
    // Validates the model and reports its diagnostics the way every command does.
    let c = io::compile(&args.model, Derive::Nothing, None)?;
    if c.has_errors() {
        return Err(Failure::Invalid);
    }
    let (_, bytes) = io::read(&args.model)?;
    let text = String::from_utf8_lossy(&bytes);
    let goal = match args.goal {
        GoalArg::Detectable => Goal::Detectable,
        GoalArg::Isolable => Goal::Isolable,
    };
    let placement = match bondgraph_core::place_sensors(&text, &args.components, goal) {
        Ok(Ok(p)) => p,
        Ok(Err(e)) => {
            return Err(report::usage(format!("{}: {e}", c.file_name)));
        }
        Err(_) => return Err(Failure::Invalid),
    };
    io::write(args.output.as_deref(), &report(&c.name, &placement))
}

fn classes(out: &mut String, title: &str, k: &NamedClasses) {
    let _ = writeln!(out, "  {title}: {} classes", k.classes.len());
    for (n, class) in k.classes.iter().enumerate() {
        let _ = writeln!(out, "    {:>3}  {}", n + 1, class.join(" "));
    }
    if !k.undetectable.is_empty() {
        let _ = writeln!(out, "    undetectable: {}", k.undetectable.join(" "));
    }
}

/// The proposals as text.
fn report(model: &str, p: &Placement) -> String {
    let mut out = String::new();
    let goal = match p.goal {
        Goal::Detectable => "detectable",
        Goal::Isolable => "as isolable as detectors can make them",
    };
    let _ = writeln!(
        out,
        "sensor placement for {model}: make {} {goal}",
        p.targets.join(" ")
    );
    classes(&mut out, "with the model's detectors", &p.now);
    classes(&mut out, "with every junction measured", &p.most);
    if p.reached {
        let _ = writeln!(out, "nothing to add: the model's detectors already do it");
        return out;
    }
    if p.proposals.is_empty() {
        let _ = writeln!(out, "no placement of detectors does it");
        return out;
    }
    let size = p.proposals[0].detectors.len();
    let _ = writeln!(
        out,
        "add {} ({size} detector{}){}:",
        if p.proposals.len() > 1 {
            "one of these sets"
        } else {
            "this"
        },
        if size == 1 { "" } else { "s" },
        if p.exhaustive {
            ""
        } else {
            ", found greedily: a smaller set may exist"
        }
    );
    for (k, q) in p.proposals.iter().enumerate() {
        let names: Vec<String> = q
            .detectors
            .iter()
            .map(|d| format!("{} on {}", d.kind, d.junction))
            .collect();
        let _ = writeln!(out, "  {}. {}", k + 1, names.join(", "));
        classes(&mut out, "   classes then", &q.classes);
    }
    out
}
