//! Options that more than one command takes: which residuals, how they are realised, how
//! expressions are simplified.

use bondgraph_core::{Limits, Realise, ResidualSet};
use clap::ValueEnum;

use crate::report::{self, Failure};

/// `--realise`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum RealiseArg {
    /// Each ARR whose derivatives enter linearly with constant coefficients as the change of
    /// its integral, reading one order of derivative fewer; the others as written.
    Lowest,
    /// Every ARR as written.
    Direct,
}

impl RealiseArg {
    fn realise(self) -> Realise {
        match self {
            RealiseArg::Lowest => Realise::Lowest,
            RealiseArg::Direct => Realise::Direct,
        }
    }
}

/// `--residuals`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ResidualsArg {
    /// One ARR per detector.
    PerSensor,
    /// The smallest set found that reaches the most isolability the candidates allow.
    Best,
    /// Every candidate with a signature of its own.
    All,
    /// Each detector's reading against a copy of the model the inputs drive from rest (the
    /// output error), one per detector.
    Simulated,
    /// Each detector's reading against a copy of the part of the model that the inputs and
    /// the other detectors' measurements drive from rest, one per detector where another
    /// detector measures a state.
    Partial,
    /// One ARR per detector and, beside them, the partial copies where the model has them.
    Bank,
}

impl ResidualsArg {
    fn set(self) -> ResidualSet {
        match self {
            ResidualsArg::PerSensor => ResidualSet::PerSensor,
            ResidualsArg::Best => ResidualSet::Best,
            ResidualsArg::All => ResidualSet::All,
            ResidualsArg::Simulated => ResidualSet::Simulated,
            ResidualsArg::Partial => ResidualSet::Partial,
            ResidualsArg::Bank => ResidualSet::Bank,
        }
    }
}

/// How expressions are written: the e-graph search for their shortest form.
/// `--residuals` and `--realise`, which every command that derives ARRs takes: which
/// residuals, and how residual generators evaluate them.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct ResidualChoice {
    /// Which residuals: one ARR per detector (as the reference paper does), the smallest
    /// set found that tells apart every fault class bgc can reach (`best`), or every
    /// candidate with a signature of its own (`all`) [default: per-sensor; for `bgc
    /// residuals` deciding on a calibration (`--calibrate`, `--calibration`), `bank`: the
    /// ARRs and, beside them, the partial copies where the model has them]
    #[arg(long, value_enum, value_name = "SET")]
    residuals: Option<ResidualsArg>,

    /// How residual generators evaluate each ARR: integrated once where that lowers the
    /// derivatives it reads (`lowest`; `bgc verify` checks such a one as its rate plus its
    /// level's derivative), or as written (`direct`).
    #[arg(long, value_enum, value_name = "HOW", default_value = "lowest")]
    realise: RealiseArg,
}

impl ResidualChoice {
    /// The residual set asked for.
    pub(crate) fn set(&self) -> ResidualSet {
        self.residuals.unwrap_or(ResidualsArg::PerSensor).set()
    }

    /// The same choice where the residuals decide on a calibration and no set was asked
    /// for: the bank, whose every residual the calibration prices, so that a fault shows
    /// in whichever sees it best.
    pub(crate) fn deciding(&self, deciding: bool) -> ResidualChoice {
        let mut choice = self.clone();
        if deciding {
            choice.residuals.get_or_insert(ResidualsArg::Bank);
        }
        choice
    }

    /// The realisation asked for.
    pub(crate) fn realise(&self) -> Realise {
        self.realise.realise()
    }

    /// `--residuals` and `--realise` as their values are spelled on the command line.
    pub(crate) fn spelled(&self) -> (String, String) {
        let spell = |v: Option<clap::builder::PossibleValue>| {
            v.map_or_else(String::new, |v| v.get_name().to_string())
        };
        (
            spell((self.residuals.unwrap_or(ResidualsArg::PerSensor)).to_possible_value()),
            spell(self.realise.to_possible_value()),
        )
    }
}

#[derive(clap::Args, Debug)]
pub(crate) struct SimplifyArgs {
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

    /// No longer used: accepted so that scripts that pass it still run, with a warning. The
    /// search stops by the counts above only, so that what is printed never depends on the
    /// machine's speed or load.
    #[arg(long, value_name = "SECONDS", hide = true)]
    egg_seconds: Option<String>,
}

impl SimplifyArgs {
    /// The limits asked for.
    pub(crate) fn limits(&self) -> Result<Option<Limits>, Failure> {
        if self.egg_seconds.is_some() {
            report::warn(
                "--egg-seconds is no longer used: the simplifier stops by counts only \
                 (--egg-nodes, --egg-iterations, --egg-rounds, --egg-budget), so that the \
                 output does not depend on the machine's speed or load",
            );
        }
        if self.canonical {
            return Ok(None);
        }
        Ok(Some(Limits {
            nodes: self.egg_nodes,
            iterations: self.egg_iterations,
            rounds: self.egg_rounds,
            budget: self.egg_budget,
        }))
    }
}

/// `--params`, which every command that evaluates a model takes.
#[derive(clap::Args, Debug, Default)]
pub(crate) struct ValuesArg {
    /// A parameter file (`NAME = VALUE` lines, as `bgc identify` writes them) whose values
    /// replace the model's.
    #[arg(long = "params", value_name = "FILE")]
    params: Option<std::path::PathBuf>,
}

impl ValuesArg {
    /// The parameter file, if one was given.
    pub(crate) fn path(&self) -> Option<&std::path::Path> {
        self.params.as_deref()
    }
}
