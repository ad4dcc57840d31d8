//! The records a calibration reads: the samples as handed over, and the healthy record with
//! where it is singular, over which every choice is made.

use bondgraph::Reference;

use crate::generator::{Estimated, Estimates, Generator};

/// A record's samples as calibration reads them.
#[derive(Clone, Debug)]
pub struct Samples<'a> {
    /// The time of each sample.
    pub time: &'a [f64],
    /// One column per raw signal of the program, in its order.
    pub columns: Vec<&'a [f64]>,
    /// The step between samples.
    pub step: f64,
}

impl Samples<'_> {
    /// How many samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
}

/// How a pass reads each residual the generator gives: as given (`None`), or its change over
/// a window of that many samples (a held residual, generated from the start).
pub(crate) type View = Vec<Option<usize>>;

/// The healthy record, with where it is singular: what the choices are made on.
pub(super) struct Healthy<'a> {
    pub(super) samples: &'a Samples<'a>,
    pub(super) singular: Singular,
}

impl Healthy<'_> {
    /// How many samples.
    pub(crate) fn len(&self) -> usize {
        self.samples.len()
    }

    /// Each residual's values over the record, one per estimate; not a number where it is
    /// singular.
    pub(crate) fn residuals(&self, generator: Generator) -> Vec<Vec<f64>> {
        self.residuals_with(generator, &self.samples.columns)
    }

    /// The same over the record's time with other columns (a replica's).
    pub(crate) fn residuals_with(&self, generator: Generator, columns: &[&[f64]]) -> Vec<Vec<f64>> {
        // An empty view reads every residual as generated.
        let viewed = self.residuals_viewed(generator, columns, &[Vec::new()], None);
        viewed.into_iter().next().unwrap_or_default()
    }

    /// The same in each view: each residual as generated, or its change over a window (see
    /// [`View`]); not a number where it is singular, after the window has read it. With
    /// `estimated`, the estimators' output over these columns is taken from there.
    pub(crate) fn residuals_viewed(
        &self,
        generator: Generator,
        columns: &[&[f64]],
        views: &[View],
        estimated: Option<&Estimated>,
    ) -> Vec<Vec<Vec<f64>>> {
        let (at, series) = self.generated(generator, columns, estimated);
        (views.iter())
            .map(|view| self.viewed(&at, &series, view))
            .collect()
    }

    /// The instant of each estimate, and each residual over them (as
    /// [`Healthy::residuals_with`] gives it).
    pub(crate) fn residuals_timed(
        &self,
        generator: Generator,
        columns: &[&[f64]],
    ) -> (Vec<f64>, Vec<Vec<f64>>) {
        let (at, series) = self.generated(generator, columns, None);
        let viewed = self.viewed(&at, &series, &Vec::new());
        (at, viewed)
    }

    /// The instant of each estimate, and each residual as generated over these columns.
    fn generated(
        &self,
        mut generator: Generator,
        columns: &[&[f64]],
        estimated: Option<&Estimated>,
    ) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut series: Vec<Vec<f64>> = Vec::new();
        let mut at: Vec<f64> = Vec::new();
        let time = self.samples.time;
        let take = |e: &Estimates<'_>| {
            if !e.is_empty() {
                series.resize(e.residual_count(), Vec::new());
            }
            at.extend_from_slice(e.at());
            for (k, s) in series.iter_mut().enumerate() {
                s.extend_from_slice(e.residual(k));
            }
        };
        match estimated {
            Some(e) => generator.run_estimated(time, columns, e, false, take),
            None => generator.run(time, columns, false, take),
        }
        (at, series)
    }

    /// Each residual of `series` (at the instants `at`) in `view`, not a number where it is
    /// singular.
    fn viewed(&self, at: &[f64], series: &[Vec<f64>], view: &View) -> Vec<Vec<f64>> {
        (series.iter().enumerate())
            .map(|(k, s)| {
                let mut window = view.get(k).copied().flatten().map(Reference::window);
                (s.iter().zip(at))
                    .map(|(&r, &t)| {
                        let r = window.as_mut().map_or(r, |w| w.push(r));
                        if self.singular.contains(k, t) {
                            f64::NAN
                        } else {
                            r
                        }
                    })
                    .collect()
            })
            .collect()
    }
}

/// A series' RMS (at least the smallest positive number), over its finite values.
pub(super) fn rms(r: &[f64]) -> f64 {
    let (sum, n) =
        (r.iter().filter(|v| v.is_finite())).fold((0.0, 0), |(s, n), v| (s + v * v, n + 1));
    (sum / (n as f64).max(1.0)).sqrt().max(f64::MIN_POSITIVE)
}

/// Per residual, the spans of time (first and last estimate's instants) where it is
/// singular, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Singular {
    /// One list of spans per residual.
    pub spans: Vec<Vec<(f64, f64)>>,
    /// Where the record starts unsettled, the instant it has settled: before it no residual
    /// is decided on (nor calibrated on), though it is evaluated, so that what the residuals
    /// integrate from the record's start (a twist from two encoders) is integrated from there.
    pub start_up: Option<f64>,
}

impl Singular {
    /// Leaves out everything before `end` (a start-up's, where there is one): the spans
    /// within it are part of it.
    pub fn start_up_until(&mut self, end: Option<f64>) {
        self.start_up = end;
        if let Some(end) = end {
            for spans in &mut self.spans {
                spans.retain(|&(_, to)| to >= end);
            }
        }
    }

    /// Whether residual `k` is singular at `t`, or `t` is in the start-up.
    pub fn contains(&self, k: usize, t: f64) -> bool {
        if self.start_up.is_some_and(|end| t < end) {
            return true;
        }
        let Some(spans) = self.spans.get(k) else {
            return false;
        };
        let after = spans.partition_point(|&(from, _)| from <= t);
        after > 0 && t <= spans[after - 1].1
    }

    /// The latest end of the spans that begin at `first` (a record's first estimate): when
    /// a record that starts singular (at rest) has settled, where it does.
    pub fn settled(&self, first: f64) -> Option<f64> {
        (self.spans.iter())
            .filter_map(|s| {
                s.first()
                    .filter(|(from, _)| *from <= first)
                    .map(|(_, to)| *to)
            })
            .fold(None, |a: Option<f64>, t| Some(a.map_or(t, |a| a.max(t))))
    }

    /// Whether no residual is singular anywhere, nor left out in a start-up.
    pub fn is_empty(&self) -> bool {
        self.start_up.is_none() && self.spans.iter().all(Vec::is_empty)
    }

    /// Each residual's spans as the notes give them: `0–0.31 s, 12.5–12.6 s`.
    pub fn said(&self, k: usize) -> String {
        let spans = &self.spans[k];
        let mut out: Vec<String> = (spans.iter().take(4))
            .map(|(a, b)| format!("{a}–{b} s"))
            .collect();
        if spans.len() > 4 {
            out.push(format!("and {} more", spans.len() - 4));
        }
        out.join(", ")
    }
}
