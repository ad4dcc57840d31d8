//! Where a relation cannot be trusted: samples at which a residual's sensitivity to the
//! measurement noise is far above its usual level. A relation that divides by a measured
//! speed is singular while the speed is at zero (every start-up), a law read the other way
//! at the edge of its domain (a square root at zero), a `sign` where its argument is within
//! the noise of zero: there the noise decides the residual, whatever the plant does. Such
//! samples are found numerically, for any relation: one draw of noise of each signal's
//! deviation is added to the record and taken away, and half the difference of the two
//! residuals is what the noise does to each residual there. Where that, at its largest over
//! an estimator's window, is [`GAIN`] times its median on the healthy record (or is not a
//! number), the residual is singular. Those samples are left out of calibration and raise
//! no alarm, and the user is told which, residual by residual.

use crate::calibrate::replicas;
use crate::calibrate::samples::Singular;
use crate::generator::Generator;
use crate::sensor::Noise;

/// How many times its healthy median a residual's sensitivity to the noise must be for its
/// samples to be singular: far above what one draw of noise gives anywhere on a record
/// (the median of a half-normal's largest of a few dozen draws is about 4 times its own).
pub const GAIN: f64 = 10.0;

/// The draw of noise singular samples are found with: beyond those of the replicas.
const DRAW: usize = 1 << 20;

/// What tells a singular sample on any record: each signal's noise deviation, and each
/// residual's median sensitivity to it on the healthy record (`None`: never singular, a
/// residual integrated from the start, which carries a singular sample for good).
#[derive(Clone, Debug, PartialEq)]
pub struct Conditioning {
    /// Each raw signal's noise deviation.
    pub deviations: Vec<f64>,
    /// Each residual's typical sensitivity to that noise.
    pub typical: Vec<Option<f64>>,
    /// Where the healthy record started unsettled, the seconds it took to settle from its
    /// first sample: a record monitored is left undecided at least that long, whether or
    /// not its own start shows it (a copy of the model starts from rest, and carries a start
    /// the record's signals no longer show: on the two-mass drive from a twisted shaft, both
    /// copies alarmed over the first 0.6 s of a record whose start-up was not found).
    pub start_up: Option<f64>,
}

impl Conditioning {
    /// The conditioning read on a healthy record, and where it is singular; residuals
    /// marked `skip` get none.
    pub(crate) fn read(
        pair: (Generator, Generator),
        time: &[f64],
        columns: &[&[f64]],
        deviations: &[f64],
        (window, skip): (usize, &[bool]),
    ) -> (Conditioning, Singular) {
        let (at, local) = local_noise(pair, time, columns, deviations, window);
        let typical = (local.iter().zip(skip))
            .map(|(l, &skip)| if skip { None } else { median(l) })
            .collect();
        let conditioning = Conditioning {
            deviations: deviations.to_vec(),
            typical,
            start_up: None,
        };
        let singular = conditioning.spans(&at, &local);
        (conditioning, singular)
    }

    /// The first sample of a record from which it has settled under `estimator` (see
    /// `settle`), where it starts unsettled: the samples before are left out of it.
    pub fn settled(
        &self,
        program: &bondgraph_core::program::Program,
        columns: &[&[f64]],
        estimator: crate::fit::Estimator,
    ) -> Option<usize> {
        let differentiated: Vec<bool> = program.raw.values().map(|r| r.order > 0).collect();
        let (window, degree) = (estimator.window(), estimator.degree());
        crate::calibrate::settle::settled(
            columns,
            &self.deviations,
            &differentiated,
            (window, degree),
        )
    }

    /// Where a record is singular, residual by residual, with the generators of its
    /// residuals as monitoring evaluates them.
    pub fn singular(
        &self,
        pair: (Generator, Generator),
        time: &[f64],
        columns: &[&[f64]],
        window: usize,
    ) -> Singular {
        if self.typical.iter().all(Option::is_none) {
            return Singular {
                spans: vec![Vec::new(); self.typical.len()],
                start_up: None,
            };
        }
        let (at, local) = local_noise(pair, time, columns, &self.deviations, window);
        self.spans(&at, &local)
    }

    /// Where a monitored record is not decided on, as calibration leaves the healthy one
    /// out: its start-up, until it has settled under `estimator` (see [`Self::settled`]) and
    /// at least as long as the healthy record took (see [`Conditioning::start_up`]), and
    /// after it the spans where each residual is singular; with the first settled sample.
    pub fn undecided(
        &self,
        program: &bondgraph_core::program::Program,
        pair: (Generator, Generator),
        time: &[f64],
        columns: &[&[f64]],
        estimator: crate::fit::Estimator,
    ) -> (Singular, Option<usize>) {
        let own = self.settled(program, columns, estimator);
        let healthy = (self.start_up.zip(time.first()))
            .map(|(s, &t0)| time.partition_point(|&t| t < t0 + s))
            .filter(|&k| k > 0 && k < time.len());
        let first = own.max(healthy);
        let mut singular = self.singular(pair, time, columns, estimator.window());
        singular.start_up_until(first.map(|k| time[k]));
        (singular, first)
    }

    /// The spans where each residual's local sensitivity `local` (at the instants `at`) is
    /// [`GAIN`] times its typical one, or not a number.
    fn spans(&self, at: &[f64], local: &[Vec<f64>]) -> Singular {
        let spans = (local.iter().zip(&self.typical))
            .map(|(l, typical)| match typical {
                None => Vec::new(),
                Some(typical) => {
                    let limit = GAIN * typical;
                    let flagged = l.iter().map(|v| v.is_nan() || *v > limit);
                    let mut spans: Vec<(f64, f64)> = Vec::new();
                    let mut open: Option<f64> = None;
                    let mut last = 0.0;
                    for (&t, flagged) in at.iter().zip(flagged) {
                        match (flagged, open) {
                            (true, None) => open = Some(t),
                            (false, Some(from)) => {
                                spans.push((from, last));
                                open = None;
                            }
                            _ => {}
                        }
                        last = t;
                    }
                    if let Some(from) = open {
                        spans.push((from, last));
                    }
                    spans
                }
            })
            .collect();
        Singular {
            spans,
            start_up: None,
        }
    }
}

/// Each residual's sensitivity to the noise along a record, at each estimate: half the
/// difference of its values with one draw of white noise of `deviations` added and taken
/// away, at its largest over `window` estimates centred there. With the estimates' instants.
/// White even for a quantised signal, of its error's deviation: what is kept for a monitored
/// record is the deviation, and a sample is singular only against the same draw's typical
/// sensitivity.
fn local_noise(
    (mut up, mut down): (Generator, Generator),
    time: &[f64],
    columns: &[&[f64]],
    deviations: &[f64],
    window: usize,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let white: Vec<Noise> = deviations.iter().map(|&d| Noise::White(d)).collect();
    let run = |generator: &mut Generator, sign: f64| {
        let noisy = replicas::perturbed(columns, &white, DRAW, sign);
        let noisy: Vec<&[f64]> = noisy.iter().map(Vec::as_slice).collect();
        let (mut at, mut series): (Vec<f64>, Vec<Vec<f64>>) = (Vec::new(), Vec::new());
        generator.run(time, &noisy, false, |e| {
            if !e.is_empty() {
                series.resize(e.residual_count(), Vec::new());
            }
            at.extend_from_slice(e.at());
            for (k, s) in series.iter_mut().enumerate() {
                s.extend_from_slice(e.residual(k));
            }
        });
        (at, series)
    };
    let (at, plus) = run(&mut up, 1.0);
    let (_, minus) = run(&mut down, -1.0);
    let local = (plus.iter().zip(&minus))
        .map(|(p, m)| {
            let half: Vec<f64> = (p.iter().zip(m))
                .map(|(p, m)| 0.5 * (p - m).abs())
                .collect();
            moving_max(&half, window)
        })
        .collect();
    (at, local)
}

/// The largest of `x` over `window` values centred on each (fewer at the ends); a value that
/// is not a number stays one, as the largest of its window.
fn moving_max(x: &[f64], window: usize) -> Vec<f64> {
    let half = window / 2;
    let mut out = Vec::with_capacity(x.len());
    // Indices of a decreasing run of values: the front is the window's largest.
    let mut run: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let key = |v: f64| if v.is_nan() { f64::INFINITY } else { v };
    let mut next = 0;
    for i in 0..x.len() {
        let last = (i + half).min(x.len() - 1);
        while next <= last {
            while run.back().is_some_and(|&j| key(x[j]) <= key(x[next])) {
                run.pop_back();
            }
            run.push_back(next);
            next += 1;
        }
        while run.front().is_some_and(|&j| j + half < i) {
            run.pop_front();
        }
        out.push(run.front().map_or(f64::NAN, |&j| x[j]));
    }
    out
}

/// The median of the finite values of `x`, where it has some above zero.
fn median(x: &[f64]) -> Option<f64> {
    let mut finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return None;
    }
    let mid = finite.len() / 2;
    let (_, m, _) = finite.select_nth_unstable_by(mid, f64::total_cmp);
    (*m > 0.0).then_some(*m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_moving_maximum_keeps_each_windows_largest() {
        let x = [1.0, 5.0, 2.0, 0.0, 0.0, 3.0, 0.0];
        assert_eq!(moving_max(&x, 3), [5.0, 5.0, 5.0, 2.0, 3.0, 3.0, 3.0]);
        assert_eq!(moving_max(&x, 1), x);
        let nan = [1.0, f64::NAN, 1.0, 1.0, 1.0];
        let m = moving_max(&nan, 3);
        assert!(m[0].is_nan() && m[2].is_nan() && m[3] == 1.0, "{m:?}");
    }

    #[test]
    fn spans_are_where_the_sensitivity_is_far_above_its_median() {
        let conditioning = Conditioning {
            deviations: vec![0.1],
            typical: vec![Some(1.0), None],
            start_up: None,
        };
        let at: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let mut local = vec![1.0; 10];
        local[0] = 50.0;
        local[1] = f64::NAN;
        local[6] = 11.0;
        let singular = conditioning.spans(&at, &[local.clone(), local]);
        assert_eq!(singular.spans[0], [(0.0, 1.0), (6.0, 6.0)]);
        assert!(singular.spans[1].is_empty());
        assert!(singular.contains(0, 0.5) && singular.contains(0, 6.0));
        assert!(!singular.contains(0, 2.0) && !singular.contains(1, 0.0));
    }
}
