//! bgc's arguments: the commands, each one's own arguments in its module.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// bgc — a bond-graph compiler for model-based fault detection.
///
/// Reads a `.bg` model (a bond graph with its sensors) and checks it or writes it out.
#[derive(Parser, Debug)]
#[command(name = "bgc", version, about, long_about = None)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(crate) struct Args {
    #[command(subcommand)]
    pub(crate) command: Option<Command>,

    /// The model to read (a `.bg` file, or `-` for standard input).
    #[arg(value_name = "MODEL", required = true)]
    pub(crate) model: Option<PathBuf>,

    /// How to write the model when no command is given.
    #[command(flatten)]
    pub(crate) emit: crate::emit::EmitArgs,
}

/// The commands; without one, bgc writes the model (`--emit`).
#[derive(Subcommand, Debug)]
pub(crate) enum Command {
    /// Check a model and print what it holds: counts of elements, bonds, junctions, detectors,
    /// and its parameters.
    Check(crate::check::CheckArgs),
    /// Check the model's ARRs and FSM numerically: every residual on simulated trajectories
    /// of the model (exact derivatives along its state equations), every FSM entry with the
    /// component faulted in the plant only. Prints a table; exits 1 on any failure.
    Verify(crate::verify::VerifyArgs),
    /// Simulate a model under a scenario (inputs, closed loops, faults, noise) and write the
    /// samples as CSV: time, inputs as commanded, states, measured signals as reported.
    Simulate(crate::simulate::SimulateArgs),
    /// Evaluate the ARRs over recorded samples (CSV: `t` and one column per input and
    /// measured signal) and write residuals, thresholds, alarms and candidate components as
    /// CSV.
    Residuals(crate::residuals::ResidualArgs),
    /// Fit the model's parameters to healthy records (least squares on the residuals as they
    /// are evaluated) and write them as a parameter file (`--params` of every command), with
    /// each estimate's 95 % interval and what the records do not determine.
    Identify(crate::identify::IdentifyArgs),
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
    Causality(crate::causality::CausalityArgs),
}
