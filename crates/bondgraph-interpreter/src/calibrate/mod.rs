//! Calibration on a healthy record: the model fitted to it, then the estimator, each
//! integrated residual's integration and each residual's threshold chosen on it, in that
//! order (each choice made under the ones before it). `bgc residuals --calibrate` and
//! Python's `calibrate=` both call [`calibrate`], so that they decide alike.

mod choose;
mod error;
mod fitted;
mod hold;
mod instants;
mod levels;
mod range;
mod rate;
mod replicas;
mod samples;
mod sequential;
mod settle;
mod singular;
mod steps;

use bondgraph_core::program::Program;
use bondgraph_core::{Compiled, Realisation, ResidualForm};

use crate::fit::{Estimator, Fit, Integration};
use crate::generator::Generator;
use crate::hold::Hold;
use crate::walk::Walk;

pub use choose::{INTEGRATIONS, MODULATING_DEFAULT, WINDOWS};
pub use error::CalibrateError;
pub use range::{beyond, said as beyond_said, Beyond, Range};
pub use rate::FalseAlarms;
pub use replicas::COUNT as REPLICAS;
use samples::Healthy;
pub use samples::{Samples, Singular};
pub use sequential::CusumLevels;
pub use singular::{Conditioning, GAIN};

/// Which kind of estimator of the signals' derivatives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EstimatorKind {
    /// Savitzky–Golay polynomial fits.
    SavitzkyGolay,
    /// Modulating functions (residuals linear in the signals only).
    Modulating,
}

impl EstimatorKind {
    /// The estimator of this kind over `window` samples, fits of degree `degree`.
    pub fn over(self, window: usize, degree: u32) -> Estimator {
        match self {
            EstimatorKind::SavitzkyGolay => Estimator::SavitzkyGolay { window, degree },
            EstimatorKind::Modulating => Estimator::Modulating { window },
        }
    }

    /// The window used when none is given nor calibrated.
    pub fn default_window(self) -> usize {
        match self {
            EstimatorKind::SavitzkyGolay => WINDOWS[0],
            EstimatorKind::Modulating => MODULATING_DEFAULT,
        }
    }
}

/// What the user fixed, and what the thresholds must state.
#[derive(Clone, Debug)]
pub struct Choices {
    /// The estimator's kind, where given; else fits, or whichever shows faults most.
    pub estimator: Option<EstimatorKind>,
    /// The estimator's window, where given.
    pub window: Option<usize>,
    /// The fits' degree.
    pub degree: u32,
    /// Every integrated residual's integration, where given.
    pub integration: Option<Integration>,
    /// A share of healthy samples allowed above the thresholds (0: none, and the thresholds
    /// state `crossing`).
    pub share: f64,
    /// The probability that a healthy record as long as the calibration's crosses a
    /// threshold.
    pub crossing: f64,
    /// How far above the healthy record's largest |r| a threshold is at least.
    pub margin: f64,
    /// Keep the model's values rather than fit them to the healthy record.
    pub keep_model: bool,
    /// Levels given, by residual: those are not calibrated.
    pub thresholds: Vec<Option<f64>>,
    /// A CUSUM beside each threshold, with this drift (in deviations of the residual's
    /// noise) at least: the stated probability is then shared between the two tests.
    pub cusum: Option<f64>,
    /// The time after a fault by which it should show, in seconds of the records' time:
    /// each hold is chosen by the margin a fault gets then. `None`: by the margin a fault
    /// that persists gets over the healthy record's length, so that it stays in alarm
    /// while it lasts.
    pub within: Option<f64>,
}

/// What a calibration chose.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibrated {
    /// The model's parameter values (fitted, unless kept).
    pub params: Vec<f64>,
    /// The combinations of parameters the fit found determined only together (each by the
    /// parameters' places): a fault's size on one of them is a ratio only.
    pub combined: Vec<Vec<usize>>,
    /// Each raw signal's range on the healthy record, in the program's order: what the
    /// thresholds were set over.
    pub ranges: Vec<Option<Range>>,
    /// The signals' estimator.
    pub estimator: Estimator,
    /// Each residual's integration (unused for those not integrated): where it has a hold,
    /// the onset window.
    pub integration: Vec<Integration>,
    /// Each integrated residual's hold, where it has one: the second test, that keeps a
    /// persistent fault in alarm after the onset window has let it go.
    pub holds: Vec<Option<Hold>>,
    /// Each residual's noise walk, where its threshold grows with it.
    pub walks: Vec<Option<Walk>>,
    /// Each residual's threshold (in its walk's deviations where it has one).
    pub levels: Vec<Option<f64>>,
    /// The probability that a healthy record as long as the calibration's crosses one.
    pub crossing: f64,
    /// What tells where a record has settled and where a residual is singular, on any record
    /// (`None` for a healthy record without noise).
    pub conditioning: Option<Conditioning>,
    /// The healthy record's first sample kept, where it starts unsettled.
    pub settled: Option<usize>,
    /// Where the healthy record is singular, residual by residual.
    pub singular: Singular,
    /// Each residual's CUSUM, where one was asked for and its noise allows it.
    pub cusum: Vec<Option<CusumLevels>>,
    /// What was chosen and why, a sentence each, for the user.
    pub notes: Vec<String>,
}

/// Calibrates the residuals of `c` on the healthy record `healthy`, starting from the model's
/// values `params`; `step` is that of the records to monitor (the healthy record's is
/// within the tolerance of it).
pub fn calibrate(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    step: f64,
    choices: &Choices,
) -> Result<Calibrated, CalibrateError> {
    // Past a millionfold margin a threshold says nothing, and 1e308 made it infinite.
    if !(0.0..=1e6).contains(&choices.margin) {
        return Err(CalibrateError::Margin(choices.margin));
    }
    if let Some(within) = choices.within.filter(|w| !(w.is_finite() && *w > 0.0)) {
        return Err(CalibrateError::Within(within));
    }
    for p in [choices.share, choices.crossing] {
        if !(0.0..1.0).contains(&p) {
            return Err(CalibrateError::Probability(p));
        }
    }
    let mut notes = Vec::new();
    let deviations = replicas::Replicas::new(healthy).deviations().to_vec();
    let n = c.arrs.len();
    let noisy = deviations.iter().any(|&d| d > 0.0);
    // Where the healthy record is singular, found first with a provisional estimator: its
    // samples there would decide every choice after.
    let provisional = (choices.estimator.unwrap_or(EstimatorKind::SavitzkyGolay))
        .over(choices.window.unwrap_or(PROVISIONAL_WINDOW), choices.degree);
    let conditioned = !program.linear() && noisy;
    let mut settled = settle_on(program, healthy, &deviations, provisional);
    let start_up = |settled: Option<usize>| settled.map(|k| healthy.time[k]);
    let mut on = Calibrating {
        c,
        program,
        healthy: Healthy {
            samples: healthy,
            singular: Singular {
                spans: vec![Vec::new(); n],
                start_up: start_up(settled),
            },
        },
        step,
        choices,
        params: params.to_vec(),
        combined: Vec::new(),
        notes: Vec::new(),
    };
    if conditioned {
        let default = vec![Integration::default(); n];
        on.healthy.singular = on.conditioning(provisional, &default, &deviations, &[])?.1;
        on.healthy.singular.start_up_until(start_up(settled));
    }
    // Thresholds set on a model that is not the plant's measure the model's error, not the
    // noise: the model is fitted to the healthy record first, from where it has settled and
    // is no longer singular.
    if !choices.keep_model {
        let first = healthy.time.get(window_of(provisional) / 2).copied();
        let singular = first.and_then(|t| on.healthy.singular.settled(t));
        let from = match (start_up(settled), singular) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        (on.params, on.combined) = fitted::fit_model(c, program, params, healthy, from, &mut notes);
    }
    notes.append(&mut on.notes);
    on.notes = notes;
    let default = vec![choices.integration.unwrap_or_default(); n];
    // While the estimator is chosen, the start-up reaches half the longest candidate window
    // further: an estimate there reads unsettled samples (a window, compared on them, would
    // be judged by the start-up, not by how it follows the signals).
    let reach = choices.window.unwrap_or(WINDOWS[WINDOWS.len() - 1]) / 2;
    let choosing = settled.map(|k| healthy.time[(k + reach).min(healthy.len() - 1)]);
    on.healthy.singular.start_up_until(choosing);
    let estimator = on.estimator(&default)?;
    // The window chosen may be longer than the provisional one, and settle later.
    if let Some(later) = settle_on(program, healthy, &deviations, estimator) {
        if settled.is_none_or(|s| later > s) {
            settled = Some(later);
        }
    }
    on.healthy.singular.start_up_until(start_up(settled));
    if let Some(first) = settled {
        on.notes.push(format!(
            "it starts unsettled, with signals the estimators' polynomials do not follow (a \
             start-up): its first {first} samples (to {} s) are left out of calibration, as \
             they are of the decisions on every record monitored with this calibration until \
             it has settled (its residuals are evaluated from the start: what they integrate \
             is integrated from there)",
            healthy.time[first]
        ));
    }
    let best = on.integrations(estimator)?;
    let (integration, walks, holds) = on.onsets_and_holds(estimator, best)?;
    let start_up_seconds = settled.map(|k| healthy.time[k] - healthy.time[0]);
    let mut conditioning = noisy.then(|| Conditioning {
        deviations: deviations.clone(),
        typical: vec![None; n],
        start_up: start_up_seconds,
    });
    if conditioned {
        let from_start: Vec<bool> = (integration.iter().zip(&c.arrs))
            .map(|(i, a)| {
                *i == Integration::Start && matches!(a.realisation, Realisation::Integrated(_))
            })
            .collect();
        let (read, singular) =
            on.conditioning(estimator, &integration, &deviations, &from_start)?;
        on.healthy.singular = singular;
        on.healthy.singular.start_up_until(start_up(settled));
        on.note_singular();
        conditioning = Some(Conditioning {
            start_up: start_up_seconds,
            ..read
        });
    }
    let crossing: Vec<f64> = (holds.iter())
        .map(|h| on.crossing() / if h.is_some() { 2.0 } else { 1.0 })
        .collect();
    let (levels, walks, holds) =
        on.thresholds(estimator, &integration, (walks, &holds), &crossing)?;
    let cusum = on.cusum(estimator, &integration, &walks)?;
    Ok(Calibrated {
        holds,
        ranges: range::ranges(healthy),
        params: on.params,
        combined: on.combined,
        estimator,
        integration,
        walks,
        levels,
        crossing: choices.crossing,
        conditioning,
        settled,
        singular: on.healthy.singular,
        cusum,
        notes: on.notes,
    })
}

/// Where `healthy` settles under `estimator` (see [`settle`]).
fn settle_on(
    program: &Program,
    healthy: &Samples<'_>,
    deviations: &[f64],
    estimator: Estimator,
) -> Option<usize> {
    let differentiated: Vec<bool> = program.raw.values().map(|r| r.order > 0).collect();
    settle::settled(
        &healthy.columns,
        deviations,
        &differentiated,
        (estimator.window(), estimator.degree()),
    )
}

/// The estimator's window while the singular samples are looked for, before it is chosen.
const PROVISIONAL_WINDOW: usize = 51;

/// An estimator's window, in samples.
pub fn window_of(estimator: Estimator) -> usize {
    estimator.window()
}

/// Each residual's threshold and the walk it grows with, where it has them, and its hold.
type Levels = (Vec<Option<f64>>, Vec<Option<Walk>>, Vec<Option<Hold>>);

/// Each residual's integration (the onset window where it is held), its walk, and its hold
/// (its reach, whether anchored, its walk).
type OnsetsAndHolds = (
    Vec<Integration>,
    Vec<Option<Walk>>,
    Vec<Option<hold::HeldBy>>,
);

/// What a calibration chooses with: the choices, the model as fitted, the healthy record.
struct Calibrating<'a> {
    c: &'a Compiled,
    program: &'a Program,
    healthy: Healthy<'a>,
    step: f64,
    choices: &'a Choices,
    params: Vec<f64>,
    combined: Vec<Vec<usize>>,
    notes: Vec<String>,
}

impl Calibrating<'_> {
    /// The healthy record's conditioning under an estimator and integrations, and where it
    /// is singular; residuals marked in `skip` are never singular.
    fn conditioning(
        &self,
        estimator: Estimator,
        integration: &[Integration],
        deviations: &[f64],
        skip: &[bool],
    ) -> Result<(Conditioning, Singular), CalibrateError> {
        let build = || self.generator(estimator, integration, &self.params);
        let skip: Vec<bool> = (0..self.c.arrs.len())
            .map(|k| skip.get(k).copied().unwrap_or(false))
            .collect();
        let samples = self.healthy.samples;
        Ok(Conditioning::read(
            (build()?, build()?),
            samples.time,
            &samples.columns,
            deviations,
            (window_of(estimator), &skip),
        ))
    }

    /// Says where the healthy record is singular, residual by residual.
    fn note_singular(&mut self) {
        let singular = &self.healthy.singular;
        let said: Vec<String> = (self.c.arrs.iter().enumerate())
            .filter(|(k, _)| !singular.spans[*k].is_empty())
            .map(|(k, a)| format!("{} at {}", a.name, singular.said(k)))
            .collect();
        if !said.is_empty() {
            self.notes.push(format!(
                "singular there, where a residual's sensitivity to the noise is over {GAIN} \
                 times its median (a division by a signal near zero, a law at the edge of its \
                 domain, a start-up): {}; those samples are left out of the thresholds, and \
                 raise no alarm on any record",
                said.join("; ")
            ));
        }
    }

    /// The probability each test is calibrated for: the stated one, shared between the
    /// thresholds and the CUSUMs where both decide.
    fn crossing(&self) -> f64 {
        match self.choices.cusum {
            Some(_) => self.choices.crossing / 2.0,
            None => self.choices.crossing,
        }
    }

    /// Each residual's CUSUM, where one is asked for and the healthy record has noise to
    /// draw again (see [`sequential`]).
    fn cusum(
        &mut self,
        estimator: Estimator,
        integration: &[Integration],
        walks: &[Option<Walk>],
    ) -> Result<Vec<Option<CusumLevels>>, CalibrateError> {
        let n = self.c.arrs.len();
        let Some(drift) = self.choices.cusum else {
            return Ok(vec![None; n]);
        };
        let replicas = replicas::Replicas::new(self.healthy.samples).with_instants(
            &|| self.generator(estimator, integration, &self.params),
            &self.healthy,
        )?;
        if !replicas.noisy() {
            self.notes.push(
                "no CUSUM: the healthy record has no noise to tell its deviation from".into(),
            );
            return Ok(vec![None; n]);
        }
        let span = sequential::bias_span(window_of(estimator));
        let levels = sequential::cusum_levels(
            &|| self.generator(estimator, integration, &self.params),
            (&self.healthy, &replicas),
            walks,
            (drift, self.crossing(), self.choices.margin),
            span,
        )?;
        let said: Vec<String> = (self.c.arrs.iter().zip(&levels))
            .map(|(a, l)| match l {
                Some(l) => format!(
                    "{} σ {:.3e} drift {:.2} level {:.1}",
                    a.name, l.sigma, l.drift, l.level
                ),
                None => format!("{} none (integrated from the start)", a.name),
            })
            .collect();
        self.notes.push(format!(
            "a CUSUM beside each threshold, on the residual over its noise's deviation, each \
             test crossed by a healthy record of its length with probability {} (the drift \
             at least {drift}, and at least the largest mean the model's error leaves over \
             the healthy record): {}",
            self.crossing(),
            said.join(", ")
        ));
        Ok(levels)
    }

    /// A generator of the residuals with these choices.
    fn generator(
        &self,
        estimator: Estimator,
        integration: &[Integration],
        params: &[f64],
    ) -> Result<Generator, CalibrateError> {
        let fit = Fit {
            step: self.step,
            estimator,
            integration: integration.to_vec(),
        };
        Ok(Generator::new(self.c, self.program, params, &fit)?)
    }

    /// The estimator: the kind and window where given; for fits, the longest steady window;
    /// where every residual is linear in the signals, the fits or modulating functions under
    /// whose thresholds a fault of a fifth of a parameter shows most.
    fn estimator(&mut self, integration: &[Integration]) -> Result<Estimator, CalibrateError> {
        let choices = self.choices;
        let kind = choices.estimator.unwrap_or(EstimatorKind::SavitzkyGolay);
        let of = |kind: EstimatorKind, window| kind.over(window, choices.degree);
        if let Some(window) = choices.window {
            return Ok(of(kind, window));
        }
        let window = match kind {
            EstimatorKind::SavitzkyGolay => {
                let build = |w| self.generator(of(kind, w), integration, &self.params);
                let estimated: Vec<bool> = (self.c.arrs.iter())
                    .map(|a| a.form != ResidualForm::Simulated)
                    .collect();
                let window = choose::longest_steady_window(&build, &self.healthy, &estimated)?;
                self.notes.push(format!(
                    "estimates over {window} samples, the longest window up to which no \
                     residual grows there"
                ));
                window
            }
            EstimatorKind::Modulating => MODULATING_DEFAULT,
        };
        if !self.program.linear() {
            return Ok(of(kind, window));
        }
        // Residuals linear in the signals hold on modulating functions' estimates at any
        // window: those compete with the fits.
        let fits = std::iter::once(of(EstimatorKind::SavitzkyGolay, window));
        let modulating = (choose::modulating_windows(&self.healthy, self.program.top_order()))
            .map(|w| of(EstimatorKind::Modulating, w));
        let candidates: Vec<Estimator> = match choices.estimator {
            None => fits.chain(modulating).collect(),
            Some(EstimatorKind::Modulating) => modulating.collect(),
            Some(EstimatorKind::SavitzkyGolay) => Vec::new(),
        };
        if candidates.is_empty() {
            return Ok(of(kind, window));
        }
        let (best, said) = choose::most_sensitive(
            &|e, p| self.generator(e, integration, p),
            &self.healthy,
            &candidates,
            &self.params,
            choices.margin,
        )?;
        self.notes.push(format!(
            "every residual is linear in the signals: estimates with what a fault of a fifth \
             of a parameter moves most, in thresholds, for the parameter that moves least \
             ({said})"
        ));
        Ok(match best {
            Estimator::SavitzkyGolay { .. } => of(EstimatorKind::SavitzkyGolay, window_of(best)),
            Estimator::Modulating { .. } => of(EstimatorKind::Modulating, window_of(best)),
        })
    }

    /// Each residual's integration (the one given, or the one under which a fault shows
    /// most: while it persists, over the healthy record, or `within` after it where that is
    /// given), and the walk of those taken from the start.
    fn integrations(
        &mut self,
        estimator: Estimator,
    ) -> Result<(Vec<Integration>, Vec<Option<Walk>>), CalibrateError> {
        let c = self.c;
        let n = c.arrs.len();
        let which: Vec<bool> = (c.arrs.iter())
            .map(|a| matches!(a.realisation, Realisation::Integrated(_)))
            .collect();
        if let Some(given) = self.choices.integration {
            return Ok((vec![given; n], vec![None; n]));
        }
        if !which.contains(&true) {
            return Ok((vec![Integration::default(); n], vec![None; n]));
        }
        // A fault that persists shows over the whole record: the reach under which it gets the
        // most margin is then the longest window the noise allows. Chosen for 1 s to 2 s
        // after a fault instead (the former default), the hold of ARR1 on 4,096-count
        // encoders was a 2,000-sample window, shorter than the square input's half-period
        // over which the armature's change shows little, and `Re` x 1.5 was in alarm on 76 %
        // of the samples after it.
        let within = (self.choices.within)
            .map(|seconds| (seconds / self.healthy.samples.step).round() as usize);
        let chosen = choose::best_integration(
            &|i| self.generator(estimator, &vec![i; n], &self.params),
            &self.healthy,
            &which,
            window_of(estimator),
            within,
        )?;
        let (integration, walks): (Vec<Integration>, Vec<Option<Walk>>) =
            chosen.into_iter().unzip();
        let said: Vec<String> = (c.arrs.iter().zip(&integration).zip(&which))
            .filter(|(_, &i)| i)
            .map(|((a, i), _)| match i {
                Integration::Window(n) => format!("{} over {n}", a.name),
                Integration::Start => format!(
                    "{} from the start (its threshold grows as its noise's random walk)",
                    a.name
                ),
            })
            .collect();
        let reach = within.unwrap_or(self.healthy.len());
        let lengths = choose::integration_lengths(self.healthy.len(), reach);
        let listed: Vec<String> = lengths.iter().map(usize::to_string).collect();
        let listed = listed.join(", ");
        let when = match self.choices.within {
            Some(w) => format!(
                "from {} s to {w} s after it (over {listed} samples, or from the start where \
                 its noise is white plus a random walk)",
                0.5 * w
            ),
            None => format!(
                "over the healthy record's length, as a fault that persists does (over {listed} \
                 samples)"
            ),
        };
        self.notes.push(format!(
            "integrated residuals taken where a fault moves them most against their noise \
             {when}: {}",
            said.join(", ")
        ));
        Ok((integration, walks))
    }

    /// Each integrated residual's onset window and hold, from the reach that gives a fault
    /// the most margin (`best`, see [`Calibrating::integrations`]): where the user gave no integration, the onset
    /// test reads the relation over a quarter of the estimators' window, and the hold
    /// reads it from the start where it is anchored, else over that reach (see
    /// [`crate::hold`]).
    fn onsets_and_holds(
        &mut self,
        estimator: Estimator,
        best: (Vec<Integration>, Vec<Option<Walk>>),
    ) -> Result<OnsetsAndHolds, CalibrateError> {
        let c = self.c;
        let n = c.arrs.len();
        let integrated: Vec<bool> = (c.arrs.iter())
            .map(|a| matches!(a.realisation, Realisation::Integrated(_)))
            .collect();
        if self.choices.integration.is_some() || !integrated.contains(&true) {
            return Ok((best.0, best.1, vec![None; n]));
        }
        let window = window_of(estimator);
        let onset = hold::onset_window(window);
        let chosen: Vec<(Integration, Option<Walk>)> = best.0.into_iter().zip(best.1).collect();
        let holds = hold::holds(
            &|| self.generator(estimator, &vec![Integration::Start; n], &self.params),
            &self.healthy,
            (&c.arrs, &integrated),
            &chosen,
            (window, onset),
        )?;
        let integration: Vec<Integration> = (chosen.iter().zip(&integrated))
            .map(|((i, _), &int)| if int { Integration::Window(onset) } else { *i })
            .collect();
        let said: Vec<String> = (c.arrs.iter().zip(&holds))
            .filter_map(|(a, h)| {
                h.map(|(i, anchored, _)| match (i, anchored) {
                    (Integration::Start, true) => format!(
                        "{} from the start (it reads a signal integrated from the start: its \
                         integral from the start is the balance itself)",
                        a.name
                    ),
                    (i, _) => format!(
                        "{} {} (restarted where an onset alarm that raised it ends)",
                        a.name,
                        match i {
                            Integration::Window(n) => format!("over {n} samples"),
                            Integration::Start => "from the start".to_string(),
                        }
                    ),
                })
            })
            .collect();
        self.notes.push(format!(
            "integrated residuals tested twice: for onsets and ends, over {onset} samples (a \
             quarter of the estimators' window, so that an intermittent fault's alarm ends \
             with it); and held, so that a persistent fault stays in alarm, by {}",
            if said.is_empty() {
                "none (no reach longer than the onset's)".to_string()
            } else {
                said.join(", ")
            }
        ));
        Ok((integration, vec![None; n], holds))
    }

    /// Each residual's threshold: the level given, else calibrated on the healthy record
    /// (see [`levels::thresholds`]); a residual with a level given loses its walk.
    fn thresholds(
        &mut self,
        estimator: Estimator,
        integration: &[Integration],
        (mut walks, holds): (Vec<Option<Walk>>, &[Option<hold::HeldBy>]),
        crossing: &[f64],
    ) -> Result<Levels, CalibrateError> {
        let choices = self.choices;
        // Held residuals are generated from the start, and read over their onset window and
        // as their hold from the same runs.
        let evaluated: Vec<Integration> = (integration.iter().zip(holds))
            .map(|(&i, h)| if h.is_some() { Integration::Start } else { i })
            .collect();
        let replicas = replicas::Replicas::new(self.healthy.samples).with_instants(
            &|| self.generator(estimator, &evaluated, &self.params),
            &self.healthy,
        )?;
        if replicas.noisy() && choices.share == 0.0 {
            let read: Vec<String> = (self.program.raw.values().zip(replicas.noises()))
                .map(|(s, n)| format!("{} {}", s.name, n.said()))
                .collect();
            let stepping: Vec<String> = (self.program.raw.values().zip(replicas.step_counts()))
                .filter(|(_, (n, _))| *n > 0)
                .map(|(s, (n, spread))| match spread.read {
                    true => format!(
                        "{} {n}, read on the record within {:.3} of an interval",
                        s.name, spread.width
                    ),
                    false => format!("{} {n}", s.name),
                })
                .collect();
            let steps = if stepping.is_empty() {
                String::new()
            } else {
                format!(
                    "; and at each step of a signal ({}), the instant it came at drawn within \
                     its sample interval, which no record tells and the plant responds to, or \
                     within the spread the residuals' answers to the healthy record's own \
                     steps read, where at least 8 tell it (a clock's steps fall at one place)",
                    stepping.join(", ")
                )
            };
            self.notes.push(format!(
                "thresholds that a healthy record of its length crosses with probability {} \
                 (at least its own largest |r| times 1 + the margin): what its noise does to \
                 the residuals, drawn {} times (fresh noise of the kind read on each signal, \
                 white of a deviation or a quantiser's, {}, added and taken away{steps}) and the maxima taken as a \
                 Gumbel law (shared equally between a residual's onset test and its hold, \
                 where it has one)",
                self.crossing(),
                replicas::COUNT,
                read.join(", ")
            ));
        }
        // Residuals whose relation reads a signal integrated from the start (the bench's
        // twist) walk and drift over a long record whatever their own integration: each
        // gets a walk, which the draws of the noise measure, and a drift allowed for. Over a
        // window, thresholds stationary by construction held for 200 s and false-alarmed on
        // 13 of 14 sine records of 3,000 s: the twist's integral drifts with what the fit
        // leaves of the gear ratio. On a record too short to tell a drift (as for a walk
        // from the start), what it would allow for is its noise: on the Table 3 bench's 3-s
        // records that hid a doubled load inertia.
        let telling = Walk::can_tell(self.healthy.len(), window_of(estimator));
        if telling && replicas.noisy() && choices.share == 0.0 {
            for (walk, arr) in walks.iter_mut().zip(&self.c.arrs) {
                // As written: an integral the realisation takes is not one.
                let integrates = arr.reads.iter().any(|r| r.integral) || !arr.integrals.is_empty();
                if integrates && walk.is_none() {
                    *walk = Some(Walk {
                        floor: 0.0,
                        rate: 0.0,
                        drift: 0.0,
                    });
                }
            }
        }
        let onset: levels::View = (integration.iter().zip(holds))
            .map(|(i, h)| match (i, h) {
                (Integration::Window(n), Some(_)) => Some(*n),
                _ => None,
            })
            .collect();
        let mut views = vec![onset];
        let mut by_view = vec![walks];
        if holds.iter().any(Option::is_some) {
            views.push(
                (holds.iter())
                    .map(|h| match h {
                        Some((Integration::Window(n), ..)) => Some(*n),
                        _ => None,
                    })
                    .collect(),
            );
            by_view.push(holds.iter().map(|h| h.and_then(|h| h.2)).collect());
        }
        let mut calibrated = levels::viewed(
            &|| self.generator(estimator, &evaluated, &self.params),
            (&self.healthy, &views),
            &mut by_view,
            (choices.share, choices.margin),
            replicas.noisy().then_some(&replicas),
            crossing,
        )?;
        let held = views.len() > 1;
        let hold_levels = if held { calibrated.pop() } else { None };
        let calibrated = calibrated.pop().unwrap_or_default();
        let hold_walks = if held { by_view.pop() } else { None };
        let mut walks = by_view.pop().unwrap_or_default();
        let drifting: Vec<String> = (self.c.arrs.iter().zip(&walks))
            .filter_map(|(a, w)| w.filter(|w| w.drift > 0.0).map(|w| (a, w)))
            .map(|(a, w)| format!("{} {:.3e} per sample", a.name, w.drift))
            .collect();
        if !drifting.is_empty() {
            self.notes.push(format!(
                "residuals integrated from the start, or reading a signal integrated from \
                 the start, may drift (the model's error integrated): each threshold grows \
                 by the healthy record's drift, times 1 + the margin, per sample: {}",
                drifting.join(", ")
            ));
        }
        let mut levels = choices.thresholds.clone();
        levels.resize(walks.len(), None);
        let given: Vec<bool> = levels.iter().map(Option::is_some).collect();
        for ((level, calibrated), walk) in levels.iter_mut().zip(calibrated).zip(&mut walks) {
            // A level the user gave is a level, not a multiple of the walk's deviation.
            if level.is_some() {
                *walk = None;
            }
            level.get_or_insert(calibrated);
        }
        // A residual whose level the user gave has that one test.
        let holds = (holds.iter().enumerate())
            .map(|(k, h)| {
                let (integration, anchored, _) = (*h)?;
                let level = hold_levels.as_ref()?.get(k).copied()?;
                (!given[k]).then_some(Hold {
                    integration,
                    anchored,
                    level,
                    walk: hold_walks
                        .as_ref()
                        .and_then(|w| w.get(k).copied().flatten()),
                })
            })
            .collect();
        Ok((levels, walks, holds))
    }
}
