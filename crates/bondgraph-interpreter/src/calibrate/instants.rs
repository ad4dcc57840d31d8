//! Where the healthy record's steps fell within their sample intervals, read from the
//! residuals' response to them.
//!
//! A step's instant within its interval is not in the samples, but the residuals answer it:
//! moving the sample that first holds the new level by ε times the jump moves the residuals
//! by ε times a response g that the generator gives, and the healthy record's residuals
//! around the step hold (θ − ½ + c) times that response, c what the model's error and the
//! recording convention add at every step alike. So each step's coefficient on g, net of a
//! level, reads its instant up to a constant, and their spread over the record's steps is the
//! spread of the instants. Steps at random instants spread as a uniform law over the interval
//! (a deviation of 1/√12); steps that a controller's clock makes (a DAC that holds its output
//! from the sample on) all fall at the same place, and the next record's will too: their
//! instants are then priced by their spread, not by the whole interval (on the bench's square
//! wave, clocked, the interval's pricing set thresholds 5 times the healthy record's largest
//! |r|).

use crate::calibrate::error::CalibrateError;
use crate::calibrate::samples::Healthy;
use crate::generator::Generator;

/// The fewest steps whose coefficients tell a spread: fewer tell nothing, and are priced over
/// the whole interval.
const FEWEST: usize = 8;

/// How far each step's sample is moved, as a share of its jump: half an interval's worth, the
/// most an instant can move it, so that the response stands above the noise.
const MOVE: f64 = 0.5;

/// The deviation of an instant uniform over its interval (in intervals): 1/√12.
const UNIFORM: f64 = 0.288_675_134_594_812_9;

/// How a column's steps are priced: the width of the uniform law their instants are drawn
/// from (in sample intervals; 1 is the whole interval), and how many steps it was read on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Spread {
    /// The width of the instants' law, in sample intervals, at most 1.
    pub(crate) width: f64,
    /// Whether it was read from the record (else it is the whole interval, too few steps
    /// telling otherwise).
    pub(crate) read: bool,
}

impl Spread {
    /// The whole interval: nothing tells where within it the steps fall.
    pub(crate) const WHOLE: Spread = Spread {
        width: 1.0,
        read: false,
    };
}

/// Each column's [`Spread`], its steps `steps` (as [`crate::calibrate::steps::steps`] finds
/// them), read through the residuals `build` generates.
pub(crate) fn spreads(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    steps: &[Vec<(usize, f64)>],
) -> Result<Vec<Spread>, CalibrateError> {
    let columns = &healthy.samples.columns;
    if steps.iter().all(|s| s.len() < FEWEST) {
        return Ok(vec![Spread::WHOLE; steps.len()]);
    }
    let (at, base) = healthy.residuals_timed(build()?, columns);
    let scales: Vec<f64> = base.iter().map(|r| robust_scale(r)).collect();
    let mut out = Vec::with_capacity(steps.len());
    for (c, column_steps) in steps.iter().enumerate() {
        if column_steps.len() < FEWEST {
            out.push(Spread::WHOLE);
            continue;
        }
        let moved = |sign: f64| -> Result<Vec<Vec<f64>>, CalibrateError> {
            let mut x = columns[c].to_vec();
            for &(k, jump) in column_steps {
                x[k] += sign * MOVE * jump;
            }
            let mut all: Vec<&[f64]> = columns.clone();
            all[c] = &x;
            Ok(healthy.residuals_timed(build()?, &all).1)
        };
        let (up, down) = (moved(1.0)?, moved(-1.0)?);
        let response: Vec<Vec<f64>> = (up.iter().zip(&down))
            .map(|(u, d)| {
                u.iter()
                    .zip(d)
                    .map(|(u, d)| (u - d) / (2.0 * MOVE))
                    .collect()
            })
            .collect();
        let time = healthy.samples.time;
        let instants: Vec<f64> = column_steps.iter().map(|&(k, _)| time[k]).collect();
        let coefficients = coefficients(&at, &instants, (&base, &response), &scales);
        out.push(spread_of(&coefficients));
    }
    Ok(out)
}

/// Each step's coefficient on the response (see the module's note), from every residual
/// that answers it, each weighted by its noise: estimates are split between steps at the
/// midpoints between their instants.
fn coefficients(
    at: &[f64],
    instants: &[f64],
    (base, response): (&[Vec<f64>], &[Vec<f64>]),
    scales: &[f64],
) -> Vec<f64> {
    let mut found = Vec::with_capacity(instants.len());
    for (s, &t) in instants.iter().enumerate() {
        let from = if s == 0 {
            f64::NEG_INFINITY
        } else {
            0.5 * (instants[s - 1] + t)
        };
        let to = instants
            .get(s + 1)
            .map_or(f64::INFINITY, |&n| 0.5 * (t + n));
        let (first, last) = (
            at.partition_point(|&a| a < from),
            at.partition_point(|&a| a < to),
        );
        let (mut xy, mut xx) = (0.0, 0.0);
        for ((r, g), scale) in base.iter().zip(response).zip(scales) {
            if let Some((cov, var)) = regression(&r[first..last], &g[first..last]) {
                xy += cov / (scale * scale);
                xx += var / (scale * scale);
            }
        }
        if xx > 0.0 && (xy / xx).is_finite() {
            found.push(xy / xx);
        }
    }
    found
}

/// The covariance and the variance (sums, not means) of `r` on `g` over the points where
/// both are finite: `r`'s coefficient on `g` with a level taken out is their ratio.
fn regression(r: &[f64], g: &[f64]) -> Option<(f64, f64)> {
    let points = || {
        r.iter()
            .zip(g)
            .filter(|(r, g)| r.is_finite() && g.is_finite())
    };
    let n = points().count() as f64;
    if n < 3.0 {
        return None;
    }
    let (mr, mg) = points().fold((0.0, 0.0), |(a, b), (r, g)| (a + r / n, b + g / n));
    let (cov, var) = points().fold((0.0, 0.0), |(c, v), (r, g)| {
        (c + (r - mr) * (g - mg), v + (g - mg) * (g - mg))
    });
    (var > 0.0).then_some((cov, var))
}

/// The spread the steps' coefficients read: their deviation as the width of a uniform law
/// (at most the whole interval), or the whole interval where too few were read. The
/// deviation is taken at its upper 95 % bound (a χ² law's, by Wilson and Hilferty's cube),
/// since a dozen steps tell it within a third or so; the noise in each coefficient adds to
/// it too: the width errs wide.
fn spread_of(coefficients: &[f64]) -> Spread {
    let n = coefficients.len();
    if n < FEWEST {
        return Spread::WHOLE;
    }
    let mean = coefficients.iter().sum::<f64>() / n as f64;
    let variance = coefficients.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let dof = (n - 1) as f64;
    let a = 2.0 / (9.0 * dof);
    let low_chi2 = dof * (1.0 - a - 1.645 * a.sqrt()).powi(3);
    let bound = (variance * dof / low_chi2).sqrt();
    Spread {
        width: (bound / UNIFORM).min(1.0),
        read: true,
    }
}

/// A residual's noise scale: the median of its magnitude over its finite values, at least the
/// smallest positive number.
fn robust_scale(r: &[f64]) -> f64 {
    let mut v: Vec<f64> = r
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    let mid = v.len() / 2;
    let median = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    median.max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Coefficients of steps at one place within their intervals, and of steps at random
    /// places: the first read as a narrow law, the second as the whole interval.
    #[test]
    fn clocked_steps_spread_narrow_and_random_ones_over_the_interval() {
        let clocked: Vec<f64> = (0..40).map(|k| 0.5 + 0.002 * (k % 3) as f64).collect();
        let spread = spread_of(&clocked);
        assert!(spread.read && spread.width < 0.02, "{spread:?}");
        let random: Vec<f64> = (0..40)
            .map(|k| bondgraph_sim::uniform(5, 0, k) - 0.5)
            .collect();
        let spread = spread_of(&random);
        assert!(spread.width > 0.8, "{spread:?}");
        assert_eq!(spread_of(&clocked[..5]), Spread::WHOLE);
    }

    /// A residual that answers each step by a decaying pulse of its instant's offset: the
    /// coefficients read each step's offset back, with a level taken out.
    #[test]
    fn each_steps_coefficient_reads_its_offset() {
        let instants = [1.0, 2.0, 3.0];
        let offsets = [0.3, -0.2, 0.1];
        let at: Vec<f64> = (0..4000).map(|k| k as f64 * 1e-3).collect();
        let pulse = |t: f64| {
            (instants.iter())
                .filter(|&&s| t >= s)
                .map(|&s| (-(t - s) * 50.0).exp())
                .sum::<f64>()
        };
        let response: Vec<f64> = at.iter().map(|&t| pulse(t)).collect();
        let base: Vec<f64> = (at.iter())
            .map(|&t| {
                let own = (instants.iter().zip(offsets))
                    .filter(|(&s, _)| t >= s)
                    .map(|(&s, o)| o * (-(t - s) * 50.0).exp())
                    .sum::<f64>();
                own + 7.0
            })
            .collect();
        let found = coefficients(&at, &instants, (&[base], &[response]), &[1.0]);
        for (f, o) in found.iter().zip(offsets) {
            assert!((f - o).abs() < 1e-2, "{found:?}");
        }
    }
}
