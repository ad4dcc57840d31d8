//! A sequential test beside each threshold, calibrated on the healthy record: a CUSUM
//! (`bondgraph::Cusum`) on the residual over its noise's deviation, for faults too small to
//! cross a threshold that persist. Its deviation and its level come from the healthy
//! record's noise drawn again, as the thresholds' do: the level is the one the largest sum
//! of a record as long as the healthy one exceeds with the stated probability. Its drift is
//! at least the user's, and at least what the model's error keeps the residual off zero along
//! the healthy record (a CUSUM sums a bias as it sums a fault).

use bondgraph::Cusum;

use crate::calibrate::error::CalibrateError;
use crate::calibrate::replicas::{self, Replicas};
use crate::calibrate::samples::Healthy;
use crate::generator::Generator;
use crate::walk::Walk;

/// One residual's CUSUM, as calibrated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CusumLevels {
    /// The deviation of the residual's noise.
    pub sigma: f64,
    /// The drift, in deviations: half the shift the test is tuned for.
    pub drift: f64,
    /// The level the larger sum must pass.
    pub level: f64,
}

impl CusumLevels {
    /// The runtime's test with these levels.
    pub fn test(self) -> Cusum {
        Cusum::new(self.sigma, self.drift, self.level)
    }
}

/// How many draws set the deviation the sums are taken in, before the draws that set the
/// level: the deviation of a residual's noise is known well from a few.
const DEVIATION_DRAWS: usize = 8;

/// Over how many samples (at least) the healthy residual's mean is read for the model's bias.
const BIAS_SPAN: usize = 1000;

/// Each residual's CUSUM (none for a residual whose noise is a walk, which a sum of its
/// values does not test), drift at least `drift` deviations and at least the largest mean of
/// the healthy residual over `span` samples, crossed by a healthy record as long as
/// `healthy` with probability `crossing`, and at least `1 + margin` times the largest sum
/// the healthy record itself reaches.
pub(super) fn cusum_levels(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    (healthy, replicas): (&Healthy<'_>, &Replicas<'_>),
    walks: &[Option<Walk>],
    (drift, crossing, margin): (f64, f64, f64),
    span: usize,
) -> Result<Vec<Option<CusumLevels>>, CalibrateError> {
    let n = walks.len();
    let mut squares = vec![(0.0, 0usize); n];
    for index in 0..DEVIATION_DRAWS {
        for (sum, noise) in squares
            .iter_mut()
            .zip(noise(build, healthy, replicas, index)?)
        {
            for v in noise.iter().filter(|v| v.is_finite()) {
                sum.0 += v * v;
                sum.1 += 1;
            }
        }
    }
    let sigma: Vec<f64> = (squares.iter())
        .map(|(s, n)| (s / (*n).max(1) as f64).sqrt())
        .collect();
    let nominal = healthy.residuals(build()?);
    let drifts: Vec<f64> = (nominal.iter().zip(&sigma))
        .map(|(r, &s)| drift.max(largest_mean(r, span) / s))
        .collect();
    let mut maxima: Vec<Vec<f64>> = vec![Vec::new(); n];
    for index in 0..replicas::COUNT {
        for (k, noise) in noise(build, healthy, replicas, index)?.iter().enumerate() {
            maxima[k].push(largest_sum(noise, sigma[k], drifts[k]));
        }
    }
    Ok((0..n)
        .map(|k| {
            let usable = walks[k].is_none() && sigma[k] > 0.0 && sigma[k].is_finite();
            let stated = replicas::gumbel_level(&maxima[k], crossing)?;
            let seen = largest_sum(&nominal[k], sigma[k], drifts[k]) * (1.0 + margin);
            usable.then_some(CusumLevels {
                sigma: sigma[k],
                drift: drifts[k],
                level: stated.max(seen),
            })
        })
        .collect())
}

/// What the `index`-th draw of noise does to each residual: half the difference of the
/// residuals with it added and taken away.
fn noise(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    replicas: &Replicas<'_>,
    index: usize,
) -> Result<Vec<Vec<f64>>, CalibrateError> {
    let (up, down) = (
        replicas.perturbed(index, 1.0),
        replicas.perturbed(index, -1.0),
    );
    let up = healthy.residuals_with(build()?, &slices(&up));
    let down = healthy.residuals_with(build()?, &slices(&down));
    Ok((up.iter().zip(&down))
        .map(|(u, d)| u.iter().zip(d).map(|(u, d)| 0.5 * (u - d)).collect())
        .collect())
}

/// Borrowed columns.
fn slices(columns: &[Vec<f64>]) -> Vec<&[f64]> {
    columns.iter().map(Vec::as_slice).collect()
}

/// The largest of a CUSUM's sums over `r`.
fn largest_sum(r: &[f64], sigma: f64, drift: f64) -> f64 {
    let mut test = Cusum::new(sigma, drift, f64::INFINITY);
    r.iter().fold(0.0, |most: f64, &v| {
        test.update(v);
        most.max(test.statistic())
    })
}

/// The span a bias is read over, for an estimator of `window` samples.
pub(super) fn bias_span(window: usize) -> usize {
    BIAS_SPAN.max(10 * window)
}

/// The largest |mean| of `r` over `span` consecutive finite samples (stepping by half a
/// span), or of all of them where there are fewer.
fn largest_mean(r: &[f64], span: usize) -> f64 {
    let finite: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    let span = span.min(finite.len()).max(1);
    (0..=finite.len() - span)
        .step_by((span / 2).max(1))
        .map(|k| (finite[k..k + span].iter().sum::<f64>() / span as f64).abs())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bias_is_the_largest_mean_over_a_span() {
        let mut r = vec![0.0; 4000];
        for v in &mut r[1000..2000] {
            *v = 2.0;
        }
        assert!((largest_mean(&r, 1000) - 2.0).abs() < 1e-12);
        assert!((largest_mean(&r, 4000) - 0.5).abs() < 1e-12);
        assert_eq!(largest_mean(&[f64::NAN], 10), 0.0);
    }

    #[test]
    fn the_largest_sum_grows_with_a_shift_beyond_the_drift() {
        let r = vec![1.0; 100];
        assert_eq!(largest_sum(&r, 1.0, 1.0), 0.0);
        assert!((largest_sum(&r, 1.0, 0.5) - 50.0).abs() < 1e-9);
    }
}
