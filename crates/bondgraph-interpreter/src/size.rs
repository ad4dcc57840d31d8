//! The size of a fault: once the residuals alarm, each parameter of each candidate
//! component fitted alone over the samples since the first alarm, each component with the
//! parameter whose change alone brings every residual closest to its noise, ranked by that;
//! and, on request, the best one's parameter followed window after window over the rest of
//! the record.

use std::sync::Mutex;

use bondgraph_core::program::Program;
use bondgraph_core::{Carried, Compiled};

use crate::fit::{Estimator, Fit, Integration};
use crate::generator::Generator;
use crate::identify::{
    identify, Determined, Identification, Origin, Prefix, Record, Settings, Span,
};

/// The Savitzky–Golay window the sizes are fitted with (as the model is by `--calibrate`).
pub const SIZE_WINDOW: usize = 51;
const WINDOW: usize = SIZE_WINDOW;

/// The fewest samples a span of a size holds: twice the estimator's window, so that a
/// fault's size reads more than one window of estimates (a heater sampled every 0.5 s held
/// 10 samples in the default 5 s, and nothing was sized).
pub const SIZE_SAMPLES: usize = 2 * SIZE_WINDOW;

/// One candidate's fit over a span.
pub struct Sized {
    /// The component.
    pub component: String,
    /// The parameter fitted, by its place in the model.
    pub parameter: usize,
    /// The fit.
    pub found: Identification,
    /// Where the residuals it fitted are taken from.
    pub origin: Origin,
    /// The cost of the next best parameter of the same component fitted alone, where it
    /// has another: two parameters of one law (a dead zone's width and its slope) may fit
    /// one span alike, and which comes first is then the noise's draw.
    pub rival: Option<f64>,
}

/// What the sizes are fitted on: the model, its (fitted) values and the record (its time
/// stamps, uniform at `step`, and each raw signal of the program, in its order).
pub struct Sizing<'a> {
    /// The model.
    pub c: &'a Compiled,
    /// Its residual program.
    pub program: &'a Program,
    /// The parameter values the sizes start from (the model's, or those fitted to a
    /// healthy record).
    pub params: &'a [f64],
    /// The record's time stamps.
    pub time: &'a [f64],
    /// The record's raw signals, in the program's order.
    pub columns: Vec<&'a [f64]>,
    /// The record's step.
    pub step: f64,
    /// The sizes' generator, with the starting values, at the samples spans have begun
    /// at (see [`Sizing::state_at`]).
    states: Mutex<Vec<State>>,
}

/// A generator that has taken a record's samples up to `begin`, its times shifted by the
/// seconds whose bits are `shift`.
struct State {
    begin: usize,
    shift: u64,
    prefix: Prefix,
}

/// What a fault's size is fitted over, given how long its first alarm lasted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SizeOver {
    /// The span asked for: the alarm lasts past it.
    Span,
    /// The first alarm's seconds: it ended within the span, an intermittent fault's episode.
    Episode(f64),
    /// The span asked for, although the first alarm (this many seconds) ended within it:
    /// shorter than a size needs, it tells nothing of how long the fault lasts (a fault that
    /// persists but shows only at some instants, an encoder's gain seen where the axis moves,
    /// flickers so), and one episode that brief cannot be sized alone.
    Brief(f64),
}

/// How many samples before a span its fit starts from the generator's state there: two
/// estimator windows, so that the estimates just before the span are there to take the
/// span's residuals from.
const LEAD: usize = 2 * WINDOW;

/// How many times [`Sizing::told`] doubles a span at most: 16 times the span asked for.
pub const DOUBLINGS: usize = 4;

/// How much more the second candidate's fit must cost than the best's for the two to be told
/// apart: both near the noise's level (1.007 and 1.392) is a draw of the noise.
pub const TOLD: f64 = 2.0;

/// The cost (the residuals' mean square over their noise's) within which residuals are at
/// the noise's level: with the starting values, they see nothing to size; after a fit, it
/// explains them (see `explains`).
pub const EXPLAINED: f64 = 2.0;

/// How many generator states a sizing keeps.
const STATES: usize = 8;

impl<'a> Sizing<'a> {
    /// The sizing of faults in the record `time` (uniform at `step`) with the raw signals
    /// `columns` (in `program`'s order), from the values `params` of the parameters of `c`.
    pub fn new(
        c: &'a Compiled,
        program: &'a Program,
        params: &'a [f64],
        time: &'a [f64],
        columns: Vec<&'a [f64]>,
        step: f64,
    ) -> Sizing<'a> {
        Sizing {
            c,
            program,
            params,
            time,
            columns,
            step,
            states: Mutex::new(Vec::new()),
        }
    }
}

impl Sizing<'_> {
    /// Each parameter of `component` fitted alone over `[from, to]` seconds, from `start`,
    /// with the residuals integrated from the span's start and from the record's (see
    /// [`Origin`]): the one parameter and origin that fit best. One parameter at a time,
    /// because that is the question (which parameter moved, by how much) and because two
    /// parameters of one law fitted together over a few seconds can trade off without
    /// bound (a dead zone's width and its sigmoid's slope, once the twist is past it).
    fn fit(
        &self,
        component: &str,
        start: &[f64],
        (from, to): (f64, f64),
        origins: &[Origin],
    ) -> Option<Sized> {
        let comp = self.c.components.values().find(|k| k.name == component)?;
        let mut fits: Vec<Sized> = (comp.parameters.iter())
            .filter_map(|p| self.fit_parameter(component, p.index(), start, (from, to), origins))
            .collect();
        fits.sort_by(|a, b| a.found.cost.1.total_cmp(&b.found.cost.1));
        let rival = fits.get(1).map(|s| s.found.cost.1);
        let mut best = fits.into_iter().next()?;
        best.rival = rival;
        Some(best)
    }

    /// `parameter` of `component` fitted alone over `[from, to]` seconds from `start`, from
    /// the origin whose residuals its change explains more of (the larger ratio of the cost
    /// before the fit to after). Not the lower cost after: the two origins' residuals are
    /// different series with different noise. Once a dead zone stops widening, residuals
    /// taken from the span's start no longer see its width; their fit wanders along a flat
    /// cost (0.59 rad to 0.42, the cost 0.371 to 0.370) and still costs less than the
    /// record-origin fit that finds it (28.6 to 1.44).
    fn fit_parameter(
        &self,
        component: &str,
        parameter: usize,
        start: &[f64],
        (from, to): (f64, f64),
        origins: &[Origin],
    ) -> Option<Sized> {
        // A drift counts from its onset: integrated from the record's start, the model's
        // `drift·t` would have drifted since t = 0, and no drift rate could fit both.
        let drift = self.is_drift(parameter);
        (origins.iter().copied())
            .filter(|&origin| !drift || origin == Origin::Span)
            .filter_map(|origin| {
                // Taken from the span's start, the residuals start half the sizes' estimator
                // window later, so that no estimate they integrate reads a sample from
                // before the fault: the fit cannot tell an estimate that smoothed the change
                // of slope at the onset from the fault itself (on an oven sampled every
                // 0.5 s, it biased the wall's tripled loss by 17 of its interval's
                // half-widths on a noise-free record). Taken from the record's start, they
                // hold the onset as the plant made it: on the bench, a dead zone tripled while
                // the shafts turn at steady speed shows in the link's law as the offset its
                // onset left, and a later start sized `gamma` instead of `j0`.
                let from = match origin {
                    Origin::Span => from + (WINDOW / 2) as f64 * self.step,
                    Origin::Record => from,
                };
                self.fit_from(component, parameter, start, Span { from, to, origin })
            })
            .max_by(|a, b| explained(a).total_cmp(&explained(b)))
    }

    fn fit_from(
        &self,
        component: &str,
        parameter: usize,
        start: &[f64],
        span: Span,
    ) -> Option<Sized> {
        // A drift is sized as one that began at the span's start: the record's clock is set
        // to zero there, so that the model's `drift·t` is the drift since then (where no
        // law reads the clock; otherwise the sensor's bias is fitted with it).
        let shift = if self.is_drift(parameter) && !self.c.reads_time {
            span.from
        } else {
            0.0
        };
        let span = Span {
            from: span.from - shift,
            to: span.to - shift,
            origin: span.origin,
        };
        let settings = Settings {
            fit: self.estimating(),
            free: self.fitted_with(parameter),
            bounded: false,
            span: Some(span),
        };
        let end = (self.time.iter())
            .position(|&t| t - shift > span.to)
            .map_or(self.time.len(), |k| (k + WINDOW).min(self.time.len()));
        // The fit starts a little before the span, from the generator's state there with
        // the starting values (those that held before the fault): not from the record's
        // start, which every evaluation would run again.
        let from = (self.time.iter())
            .position(|&t| t - shift >= span.from)
            .unwrap_or(self.time.len());
        let begin = from.saturating_sub(LEAD).min(end);
        // Only where the residuals are taken from the span's start: one integrated from the
        // record's start reads the parameter over all of it (a fault there all along), and
        // from a state it would read the parameter changed from a few samples before the
        // first alarm, not from the fault's onset, which the alarm precedes by up to the
        // estimators' lookahead: on the bench, a dead zone tripled 0.2 s too early leaves
        // an offset in the link's law integrated from the start that no width fits.
        let warm = begin >= LEAD && span.origin == Origin::Span;
        let state = warm.then(|| self.state_at(begin, shift, &settings.fit));
        let state = state.flatten();
        let begin = if state.is_some() { begin } else { 0 };
        let time: Vec<f64> = self.time[begin..end].iter().map(|t| t - shift).collect();
        let record = Record {
            time: &time,
            raw: self.columns.iter().map(|c| &c[begin..end]).collect(),
            state: state.as_ref(),
        };
        let found = identify(self.c, self.program, start, &[record], &settings).ok()?;
        // Residuals at the noise's level with the starting values see nothing to size: a
        // fit of them wanders along a flat cost (on the bench's square input, whose twist
        // rests past the dead zone, a width fitted from the span's start "explained" a
        // tripled dead zone at 1.000× and ranked first by its low cost).
        if found.cost.0 <= EXPLAINED {
            return None;
        }
        // A parameter the fit ran away with (held at its start) is no size: a change of it
        // alone does not explain the residuals, and a ratio of 1e198 would rank first.
        if !found.lost.is_empty() {
            return None;
        }
        // One no residual reads (an encoder's bias where only its speed is read) explains
        // nothing: its unchanged cost is no fit, however low.
        let fitted = (found.estimates.iter()).any(|e| {
            e.parameter == parameter
                && matches!(
                    e.determined,
                    Determined::Yes | Determined::Weakly | Determined::No
                )
        });
        if !fitted {
            return None;
        }
        Some(Sized {
            component: component.to_string(),
            parameter,
            found,
            origin: span.origin,
            rival: None,
        })
    }

    /// What a size is fitted over when `span` seconds are asked for and the first alarm
    /// `ended` that many seconds after it began (`None`: it did not): its seconds, where it
    /// ended within the span and held the samples a size needs (see [`SizeOver`]).
    pub fn over(&self, ended: Option<f64>, span: f64) -> SizeOver {
        match ended.filter(|&d| d < span) {
            None => SizeOver::Span,
            Some(alarm) if self.span(alarm) > alarm => SizeOver::Brief(alarm),
            Some(alarm) => SizeOver::Episode(alarm),
        }
    }

    /// The span (seconds) a size is fitted over when `span` is asked for: at least
    /// [`SIZE_SAMPLES`] of the record's steps.
    pub fn span(&self, span: f64) -> f64 {
        span.max(SIZE_SAMPLES as f64 * self.step)
    }

    /// Each candidate of `ranked` (component names, best first, as the episode ranks them)
    /// that has parameters, fitted alone over `span` seconds from `first` (widened to
    /// [`Sizing::span`]), best fit first.
    ///
    /// The residuals are taken from the span's start first; from the record's start too
    /// only where no candidate's fit explains them (see [`EXPLAINED`]): run from the
    /// record's start at each evaluation, those fits cost ten times the pass on a 10^6-row
    /// record with the fault half-way, and where the span's residuals are explained they
    /// have nothing left to tell.
    pub fn candidates(&self, ranked: &[String], first: f64, span: f64) -> Vec<Sized> {
        let span = (first, first + self.span(span));
        let fits = |origins: &[Origin]| {
            let mut sized: Vec<Sized> = (ranked.iter())
                .filter_map(|name| self.fit(name, self.params, span, origins))
                .collect();
            sized.sort_by(|a, b| a.found.cost.1.total_cmp(&b.found.cost.1));
            sized
        };
        let sized = fits(&[Origin::Span]);
        if sized.first().is_some_and(explains) {
            return sized;
        }
        fits(&[Origin::Span, Origin::Record])
    }

    /// As [`Sizing::candidates`], the span doubled while the best two candidates' fits are
    /// not told apart (the second's cost under [`TOLD`] times the best's), nor the best
    /// candidate's two best parameters (see [`Sized::rival`]), and the doubled
    /// span ends by `end`, at most [`DOUBLINGS`] times: over a span much shorter than the
    /// plant's time constants, a change that shows only in its transients (an oven's casing
    /// capacity halved) fits as well as one of its statics (the casing's loss), and which
    /// comes first is the noise's draw. Not where the two fit equally to rounding: a drive's
    /// offset and an unmeasured force read alike on every span. With the span fitted over.
    pub fn told(&self, ranked: &[String], first: f64, span: f64, end: f64) -> (Vec<Sized>, f64) {
        let mut span = self.span(span);
        let mut sized = self.candidates(ranked, first, span);
        for _ in 0..DOUBLINGS {
            let costs: Vec<f64> = sized.iter().take(2).map(|s| s.found.cost.1).collect();
            let apart = apart(&costs, sized.first().and_then(|s| s.rival));
            if apart || first + 2.0 * span > end {
                break;
            }
            span *= 2.0;
            sized = self.candidates(ranked, first, span);
        }
        (sized, span)
    }

    /// The parameter `best` sized, fitted over successive windows of `span` seconds (widened
    /// to [`Sizing::span`]) from
    /// `first` to the record's end, each from the fit of the one before: the same parameter
    /// and origin throughout, so that its trend is one series.
    pub fn follow(&self, best: &Sized, first: f64, span: f64) -> Vec<(f64, f64, Sized)> {
        let span = self.span(span);
        let end = self.time.last().copied().unwrap_or(first);
        let mut start = self.params.to_vec();
        let mut out = Vec::new();
        let mut from = first;
        while from + span <= end + 1e-9 {
            let fitted = self.fit_parameter(
                &best.component,
                best.parameter,
                &start,
                (from, from + span),
                &[best.origin],
            );
            let Some(sized) = fitted else {
                break;
            };
            start.clone_from(&sized.found.values);
            out.push((from, from + span, sized));
            from += span;
        }
        out
    }
}

impl Sizing<'_> {
    /// How the sizes' residuals are estimated.
    fn estimating(&self) -> Fit {
        Fit {
            step: self.step,
            estimator: Estimator::SavitzkyGolay {
                window: WINDOW,
                degree: self.program.top_order().max(3),
            },
            // Integrated from the span's start: what a fault adds to a relation while it
            // lasts accumulates over it, the noise only as its square root.
            integration: vec![Integration::Start; self.c.arrs.len()],
        }
    }

    /// The sizes' generator with the starting values after the record's first `begin`
    /// samples (times shifted by `shift`): run on from the latest state kept before
    /// `begin`, so that the spans of one record cost one pass between them. `None` where
    /// the generator cannot be built.
    fn state_at(&self, begin: usize, shift: f64, fit: &Fit) -> Option<Prefix> {
        let mut states = self.states.lock().ok()?;
        let shift_bits = shift.to_bits();
        let nearest = (states.iter())
            .filter(|s| s.shift == shift_bits && s.begin <= begin)
            .max_by_key(|s| s.begin);
        let (from, mut prefix) = match nearest {
            Some(s) => (s.begin, s.prefix.clone()),
            None => {
                let fresh = Generator::new(self.c, self.program, self.params, fit).ok()?;
                (0, Prefix::new(fresh, &self.columns))
            }
        };
        if from < begin {
            let time: Vec<f64> = self.time[from..begin].iter().map(|t| t - shift).collect();
            let raw: Vec<&[f64]> = self.columns.iter().map(|c| &c[from..begin]).collect();
            prefix.advance(&time, &raw);
            if states.len() == STATES {
                states.remove(0);
            }
            states.push(State {
                begin,
                shift: shift_bits,
                prefix: prefix.clone(),
            });
        }
        Some(prefix)
    }

    /// Whether `parameter` is a sensor's drift.
    fn is_drift(&self, parameter: usize) -> bool {
        (self.c.parameters.values().nth(parameter))
            .and_then(|p| p.carried.as_ref())
            .is_some_and(|f| f.fault == Carried::Drift)
    }

    /// The parameters fitted when `parameter` is sized: itself, and for a sensor's drift in a
    /// model whose laws read the clock the same sensor's bias, since a drift that began at
    /// some instant reads from then on as `drift·t` less the bias it would have had by then.
    fn fitted_with(&self, parameter: usize) -> Vec<usize> {
        let carried =
            |k: usize| (self.c.parameters.values().nth(k)).and_then(|p| p.carried.clone());
        let mut free = vec![parameter];
        let drift = carried(parameter).filter(|f| f.fault == Carried::Drift);
        if let Some(drift) = drift.filter(|_| self.c.reads_time) {
            free.extend((0..self.params.len()).filter(|&k| {
                carried(k).is_some_and(|f| f.fault == Carried::Bias && f.by == drift.by)
            }));
        }
        free
    }
}

/// Whether the best two candidates' costs (`costs`, best first) are told apart, and the
/// best one's from its `rival` parameter's: the second's at least [`TOLD`] times the
/// best's, or equal to rounding (a drive's offset and an unmeasured force read alike on
/// every span). A rival matters too: on a sine, a dead zone tripled fitted its slope
/// 51-fold over 5 s (cost 1.001, its width close behind), and its width 3.002-fold over 10 s.
fn apart(costs: &[f64], rival: Option<f64>) -> bool {
    let told = |a: f64, b: f64| b >= TOLD * a || (b - a).abs() <= 1e-6 * a.abs();
    let candidates = match costs {
        [a, b, ..] => told(*a, *b),
        _ => true,
    };
    let own = match (costs.first(), rival) {
        (Some(&a), Some(b)) => told(a, b),
        _ => true,
    };
    candidates && own
}

/// Whether a fit explains its residuals: brings them within [`EXPLAINED`] of the noise, from
/// at least [`TOLD`] times as far (on the bench's square input, a link's stiffness moved
/// by 1 % brought residuals from 2.12 to 1.82 while the dead zone had tripled).
fn explains(s: &Sized) -> bool {
    let (before, after) = s.found.cost;
    after <= EXPLAINED && before >= TOLD * after
}

/// How much of a fit's residuals its parameter's change explains: the cost before over after.
fn explained(s: &Sized) -> f64 {
    let (before, after) = s.found.cost;
    if after > 0.0 {
        before / after
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At 1 kHz a size needs 0.102 s: EMPS's pulses (alarms of 0.47 s) are sized over an
    /// episode; a flickering alarm of 20 ms (an encoder's gain on the real axis, seen where
    /// it moves) over the span asked for, as the fault persists.
    /// Two candidates, or the best one's two parameters, within [`TOLD`] of each other are
    /// not told apart; equal to rounding, or far apart, they are.
    #[test]
    fn sizes_are_told_apart_by_candidates_and_by_the_best_ones_parameters() {
        assert!(apart(&[1.0, 3.0], None));
        assert!(!apart(&[1.0, 1.5], None));
        assert!(apart(&[1.0, 1.0], None));
        assert!(apart(&[1.0], None));
        assert!(!apart(&[1.001, 6397.0], Some(1.2)));
        assert!(apart(&[1.094, 6397.0], Some(4.0)));
        assert!(!apart(&[1.0], Some(1.9)));
    }

    #[test]
    fn a_size_is_fitted_over_an_episode_only_where_it_holds_a_sizes_samples() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/dc_motor.bg"
        ))
        .expect("model");
        let out = bondgraph_core::compile(&text, "m.bg", &bondgraph_core::Options::default())
            .expect("compiles");
        let c = &out.compiled;
        let program = c.program();
        let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
        let sizing = Sizing::new(c, &program, &params, &[], Vec::new(), 1e-3);
        assert_eq!(sizing.over(None, 5.0), SizeOver::Span);
        assert_eq!(sizing.over(Some(7.0), 5.0), SizeOver::Span);
        assert_eq!(sizing.over(Some(0.465), 5.0), SizeOver::Episode(0.465));
        assert_eq!(sizing.over(Some(0.02), 5.0), SizeOver::Brief(0.02));
        assert_eq!(sizing.over(Some(0.0), 5.0), SizeOver::Brief(0.0));
    }
}
