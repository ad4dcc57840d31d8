//! What a healthy record's noise does to the residuals, drawn again: a threshold is a
//! statement about the next record, and one record's maximum is one draw of an extreme value,
//! with its noise's slow parts (an integral's start, a twist integrated from two encoders)
//! drawn once. Each signal's noise is read from the record, and fresh noise of that deviation
//! is added to it and taken away: half the difference of the two residuals is what such noise
//! does, to first order exactly and to second order too (the even terms cancel), around the
//! plant's actual trajectory. (A smoother cannot take the record's own noise out first: what it
//! leaves is the noise in the signals' band, which is what the residuals see.)

use crate::calibrate::error::CalibrateError;
use crate::calibrate::instants::{self, Spread};
use crate::calibrate::samples::{Healthy, Samples};
use crate::calibrate::steps::steps;
use crate::generator::Generator;
use crate::sensor::{Counter, Noise};

/// How many draws of noise a calibration makes (each evaluated twice): the maxima of as many
/// records, from which the level a record crosses with a stated probability is extrapolated.
pub const COUNT: usize = 64;

/// Where the replicas' noise comes from: distinct from any scenario's seeds, so that a
/// record `bgc simulate` wrote with noise is not replicated with its own numbers.
const SEED: u64 = 0x6263_6361_6c69_6272;

/// The healthy record, each of its columns' noise (see [`crate::sensor`]) and its
/// deviation, and each column's steps (see [`steps`]) with how their instants are drawn.
pub(crate) struct Replicas<'a> {
    record: &'a Samples<'a>,
    noises: Vec<Noise>,
    deviations: Vec<f64>,
    steps: Vec<Vec<(usize, f64)>>,
    spreads: Vec<Spread>,
}

impl<'a> Replicas<'a> {
    /// The record with its columns' noise and steps read.
    pub(crate) fn new(record: &'a Samples<'a>) -> Replicas<'a> {
        let noises: Vec<Noise> = record.columns.iter().map(|x| Noise::read(x)).collect();
        let deviations: Vec<f64> = noises.iter().map(Noise::deviation).collect();
        let steps: Vec<Vec<(usize, f64)>> = (record.columns.iter().zip(&deviations))
            .map(|(x, &sigma)| steps(x, sigma))
            .collect();
        Replicas {
            record,
            spreads: vec![Spread::WHOLE; steps.len()],
            noises,
            deviations,
            steps,
        }
    }

    /// The same, with each column's steps' instants drawn as the healthy record's fell (see
    /// [`instants`]), read through the residuals `build` generates.
    pub(crate) fn with_instants(
        mut self,
        build: &dyn Fn() -> Result<Generator, CalibrateError>,
        healthy: &Healthy<'_>,
    ) -> Result<Replicas<'a>, CalibrateError> {
        self.spreads = instants::spreads(build, healthy, &self.steps)?;
        Ok(self)
    }

    /// Whether any column is noisy or steps: a record with neither has nothing to
    /// replicate.
    pub(crate) fn noisy(&self) -> bool {
        self.deviations.iter().any(|&s| s > 0.0) || self.steps.iter().any(|s| !s.is_empty())
    }

    /// Each column's noise deviation (one sample's).
    pub(crate) fn deviations(&self) -> &[f64] {
        &self.deviations
    }

    /// Each column's noise, as the note gives it.
    pub(crate) fn noises(&self) -> &[Noise] {
        &self.noises
    }

    /// How many steps each column takes, and how their instants are drawn, as the note
    /// gives them.
    pub(crate) fn step_counts(&self) -> Vec<(usize, Spread)> {
        self.steps
            .iter()
            .map(Vec::len)
            .zip(self.spreads.iter().copied())
            .collect()
    }

    /// The record's columns with the `index`-th draw of fresh noise added (`sign` 1) or
    /// taken away (`sign` −1).
    pub(crate) fn perturbed(&self, index: usize, sign: f64) -> Vec<Vec<f64>> {
        (self.record.columns.iter().zip(self.noise(index)))
            .map(|(x, e)| x.iter().zip(e).map(|(x, e)| x + sign * e).collect())
            .collect()
    }

    /// The `index`-th draw of fresh noise alone, what [`Replicas::perturbed`] adds: noise
    /// of each column's kind (white, or a quantiser's) and, at each of its steps, the change
    /// of the sample that an instant drawn uniformly within the step's interval (or within
    /// the spread the healthy record's steps showed, see [`instants`]) makes (see [`steps`]).
    pub(crate) fn noise(&self, index: usize) -> Vec<Vec<f64>> {
        let columns = self.record.columns.iter().zip(&self.noises);
        (columns
            .zip(self.steps.iter().zip(&self.spreads))
            .enumerate())
        .map(|(c, ((x, noise), (steps, spread)))| {
            let stream = (index as u64) << 32 | c as u64;
            let mut e = noise.draw(x.len(), &mut Counter { seed: SEED, stream });
            for &(k, jump) in steps {
                let place = bondgraph_sim::uniform(SEED, stream, k as u64) - 0.5;
                e[k] += jump * spread.width * place;
            }
            e
        })
        .collect()
    }
}

/// `columns` with the `index`-th draw of fresh noise of the kinds `noises` added (`sign` 1)
/// or taken away (`sign` −1): without the steps' instants, which move where the record
/// steps, not how well it is conditioned.
pub(crate) fn perturbed(
    columns: &[&[f64]],
    noises: &[Noise],
    index: usize,
    sign: f64,
) -> Vec<Vec<f64>> {
    (columns.iter().zip(noises).enumerate())
        .map(|(c, (x, noise))| {
            let stream = (index as u64) << 32 | c as u64;
            let e = noise.draw(x.len(), &mut Counter { seed: SEED, stream });
            x.iter().zip(e).map(|(v, e)| v + sign * e).collect()
        })
        .collect()
}

/// The level that the largest of a record's values (normalised) exceeds with probability `p`,
/// from the maxima of `maxima.len()` draws as a Gumbel law (the law of the largest of many
/// weakly dependent values whose tails fall off no slower than exponentially). Its location
/// and scale come from the maxima's first two L-moments (`β = λ₂ / ln 2`, `μ = λ₁ − γ β`),
/// which a single large draw moves less than it moves the variance; each is then taken a
/// standard error (about `β / √n` for both) on the safe side, as a few dozen maxima tell
/// them only so well. `None` for fewer than 8 maxima.
pub(crate) fn gumbel_level(maxima: &[f64], p: f64) -> Option<f64> {
    let n = maxima.len();
    if n < 8 || maxima.iter().any(|m| !m.is_finite()) {
        return None;
    }
    let mut sorted = maxima.to_vec();
    sorted.sort_by(f64::total_cmp);
    let l1 = sorted.iter().sum::<f64>() / n as f64;
    let b1 = (sorted.iter().enumerate())
        .map(|(i, x)| i as f64 / (n - 1) as f64 * x)
        .sum::<f64>()
        / n as f64;
    let l2 = 2.0 * b1 - l1;
    let error = 1.0 / (n as f64).sqrt();
    let beta = l2 / std::f64::consts::LN_2 * (1.0 + error);
    let location = l1 - 0.577_215_664_901_532_9 * beta + beta * error;
    Some(location - beta * (-(-p).ln_1p()).ln())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_white_noise_deviation_is_read_through_a_signal_and_its_jumps() {
        let n = 100_000;
        let x: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let square = if (t / 5.0) as u64 % 2 == 0 { 5.0 } else { 15.0 };
                square + (0.5 * t).sin() + 0.01 * bondgraph_sim::gaussian(3, 0, k as u64)
            })
            .collect();
        let sigma = Noise::read(&x).deviation();
        assert!((sigma / 0.01 - 1.0).abs() < 0.03, "{sigma}");
        let clean: Vec<f64> = (0..n).map(|k| (k as f64 * 1e-3).sin()).collect();
        assert!(Noise::read(&clean).deviation() < 1e-9);
    }

    /// A heater switched between 0 and 300 W with no noise: the draws change only the
    /// samples that first hold a new level, each by up to half its step, one way or the
    /// other; a record with neither noise nor steps has nothing to replicate.
    #[test]
    fn the_draws_move_each_step_by_up_to_half_of_it() {
        let time: Vec<f64> = (0..4_000).map(|k| 0.5 * k as f64).collect();
        let heater: Vec<f64> = (0..4_000)
            .map(|k| if (k / 700) % 2 == 0 { 0.0 } else { 300.0 })
            .collect();
        let samples = Samples {
            time: &time,
            columns: vec![&heater],
            step: 0.5,
        };
        let replicas = Replicas::new(&samples);
        assert!(replicas.noisy());
        assert_eq!(replicas.step_counts(), [(5, Spread::WHOLE)]);
        let draws: Vec<Vec<f64>> = (0..COUNT).map(|i| replicas.noise(i).remove(0)).collect();
        for draw in &draws {
            for (k, e) in draw.iter().enumerate() {
                if k % 700 == 0 && k > 0 {
                    assert!(e.abs() <= 150.0, "{k} {e}");
                } else {
                    assert_eq!(*e, 0.0, "{k}");
                }
            }
        }
        let at_first: Vec<f64> = draws.iter().map(|d| d[700]).collect();
        let (lo, hi) = (at_first.iter()).fold((0.0f64, 0.0f64), |(l, h), &e| (l.min(e), h.max(e)));
        assert!(lo < -100.0 && hi > 100.0, "{lo} {hi}");
        let flat = vec![1.0; 4_000];
        let quiet = Samples {
            time: &time,
            columns: vec![&flat],
            step: 0.5,
        };
        assert!(!Replicas::new(&quiet).noisy());
    }

    #[test]
    fn the_gumbel_level_is_that_of_a_gumbel_law() {
        // Maxima of a standard Gumbel law at evenly spread probabilities: the level for
        // p = 1e-3 is −ln(−ln(1 − p)) ≈ 6.907, raised by the standard errors.
        let maxima: Vec<f64> = (1..=400)
            .map(|i| -(-(i as f64 / 401.0).ln()).ln())
            .collect();
        let level = gumbel_level(&maxima, 1e-3).unwrap();
        assert!(level > 6.9 && level < 7.4, "{level}");
        assert_eq!(gumbel_level(&maxima[..5], 1e-3), None);
    }
}
