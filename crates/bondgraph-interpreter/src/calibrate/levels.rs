//! Each residual's threshold, calibrated on a healthy record: a statement about the next
//! record, from what the healthy record's noise, drawn again, does to the residuals.

use crate::calibrate::error::CalibrateError;
use crate::calibrate::replicas::{self, Replicas};
use crate::calibrate::samples::Healthy;
pub(super) use crate::calibrate::samples::View;
use crate::generator::{Estimated, Generator};
use crate::walk::Walk;

/// Each residual's (1 − rate) quantile of |r| over a healthy record, times 1 + margin; where a
/// residual's noise follows a [`Walk`], of |r| over the walk's deviation, which the threshold
/// is then multiplied by at each sample. With adaptive thresholds this is the margin for noise
/// and estimation error, added to the bound from parameter uncertainty: a healthy record taken
/// at the nominal parameters shows what the noise does, and nothing of what the uncertainty
/// may do.
///
/// With no false alarm allowed (`rate` 0) the threshold is also a statement about the next
/// record: at least the level a record of the same length crosses with probability
/// `crossing`, from what the healthy record's noise, drawn again, does to the residuals
/// (see [`replicas`]) where the record has noise to read, else from the walk's or the
/// record's own excursions.
pub(super) fn thresholds(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    walks: &mut [Option<Walk>],
    rate_margin: (f64, f64),
    replicas: Option<&Replicas<'_>>,
    crossing: &[f64],
) -> Result<Vec<f64>, CalibrateError> {
    let view = vec![None; walks.len()];
    let mut by_view = vec![walks.to_vec()];
    let levels = viewed(
        build,
        (healthy, &[view]),
        &mut by_view,
        rate_margin,
        replicas,
        crossing,
    )?;
    walks.copy_from_slice(&by_view[0]);
    Ok(levels.into_iter().next().unwrap_or_default())
}

/// [`thresholds`] for several readings (`views`) of the same residuals, each with its
/// walks, from one run of the generator per draw: a held residual, generated from the start,
/// is read over its onset window in one view and as its hold in another.
pub(super) fn viewed(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    (healthy, views): (&Healthy<'_>, &[View]),
    walks: &mut [Vec<Option<Walk>>],
    (rate, margin): (f64, f64),
    replicas: Option<&Replicas<'_>>,
    crossing: &[f64],
) -> Result<Vec<Vec<f64>>, CalibrateError> {
    let columns = &healthy.samples.columns;
    // The draws of noise reuse the record's estimators' output (see [`pair`]), unless it
    // is too large to keep.
    let record = build()?
        .estimated(healthy.samples.time, columns)
        .small_enough();
    let raw = healthy.residuals_viewed(build()?, columns, views, record.as_ref());
    let record = record.as_ref();
    // A walk read from one record's changes over two lags misses a slow one that only its
    // whole length shows: the draws of its noise show it at every sample.
    let mut errors = vec![vec![0.0; crossing.len()]; views.len()];
    if let Some(replicas) = replicas.filter(|_| rate == 0.0) {
        let profiles = walk_profiles(build, (healthy, replicas, views, record), walks)?;
        for ((walks, profiles), errors) in walks.iter_mut().zip(profiles).zip(&mut errors) {
            for ((w, profile), error) in walks.iter_mut().zip(profiles).zip(errors) {
                if let (Some(w), Some(p)) = (w.as_mut(), profile) {
                    w.floor = w.floor.max(p.floor);
                    w.rate = w.rate.max(p.rate);
                    *error = p.slope_error;
                }
            }
        }
    }
    for walks in walks.iter_mut() {
        // A walk the draws were to measure and could not is none.
        for w in walks.iter_mut() {
            if w.is_some_and(|w| {
                (w.floor + w.rate).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            }) {
                *w = None;
            }
        }
    }
    // A residual integrated from the start may drift (the model's error integrated): the
    // threshold allows for it, and the healthy record is read net of it.
    for ((walks, raw), errors) in walks.iter_mut().zip(&raw).zip(&errors) {
        for ((w, r), error) in walks.iter_mut().zip(raw).zip(errors) {
            if let Some(w) = w {
                w.drift = Walk::drift_of(r, *error, margin);
            }
        }
    }
    let walks: &[Vec<Option<Walk>>] = walks;
    let length = healthy.len();
    let replicated = match replicas.filter(|_| rate == 0.0) {
        Some(replicas) => {
            let draws = (healthy, replicas, views, record);
            replica_levels(build, draws, walks, crossing)?
        }
        None => vec![vec![None; crossing.len()]; views.len()],
    };
    Ok((raw.into_iter().zip(walks).zip(replicated))
        .map(|((raw, walks), replicated)| {
            let series = net_of_drift(raw, walks);
            (series.into_iter().zip(walks).zip(replicated).zip(crossing))
                .map(|(((s, walk), replicated), &crossing)| {
                    // A residual that is not a number somewhere (singular at rest) says
                    // nothing there: the quantile is that of the samples where it is one.
                    let stated = replicated.unwrap_or_else(|| match walk {
                        Some(walk) if walk.rate > 0.0 => walk.crossing_level(length, crossing),
                        _ => rice_level(&s, length, crossing),
                    });
                    let mut s: Vec<f64> = (s.into_iter())
                        .filter(|v| v.is_finite())
                        .map(f64::abs)
                        .collect();
                    s.sort_by(f64::total_cmp);
                    // The sample with a share `rate` of the others above it.
                    let above = (rate * s.len() as f64).floor() as usize;
                    let at = s.len().saturating_sub(above + 1);
                    let seen = s.get(at).copied().unwrap_or(0.0) * (1.0 + margin);
                    // With no false alarm allowed, a statement about the next records too.
                    if rate == 0.0 {
                        seen.max(stated)
                    } else {
                        seen
                    }
                })
                .collect()
        })
        .collect())
}

/// How many draws of the noise measure how a walk's variance grows.
const PROFILE_DRAWS: usize = 8;

/// What the draws of a healthy record's noise say of a residual integrated from the start.
#[derive(Clone, Copy)]
struct Profile {
    /// Its noise's mean square at the start.
    floor: f64,
    /// Its growth per sample.
    rate: f64,
    /// The standard error of a least-squares slope of the residual over the record, under
    /// that noise.
    slope_error: f64,
}

/// For each residual with a walk, its noise's mean square at each sample from the start, as
/// [`PROFILE_DRAWS`] draws of the healthy record's noise give it, fitted by least squares as
/// `floor + rate * k` (each at least 0), and the spread of the draws' slopes; `None` for the
/// others.
fn walk_profiles(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    draws: Draws<'_>,
    walks: &[Vec<Option<Walk>>],
) -> Result<Vec<Vec<Option<Profile>>>, CalibrateError> {
    let views = draws.2;
    let n = walks.first().map_or(0, Vec::len);
    let mut squares: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); n]; views.len()];
    let mut slopes = vec![vec![0.0; n]; views.len()];
    let measured = |v: usize, k: usize| walks[v][k].is_some();
    if (0..views.len()).all(|v| (0..n).all(|k| !measured(v, k))) {
        return Ok(vec![(0..n).map(|_| None).collect(); views.len()]);
    }
    for index in 0..PROFILE_DRAWS {
        let [up, down] = pair(build, draws, index)?;
        for v in 0..views.len() {
            for k in (0..n).filter(|&k| measured(v, k)) {
                let noise: Vec<f64> = (up[v][k].iter().zip(&down[v][k]))
                    .map(|(u, d)| 0.5 * (u - d))
                    .collect();
                slopes[v][k] += crate::walk::slope(&noise, 0).powi(2) / PROFILE_DRAWS as f64;
                squares[v][k].resize(noise.len(), 0.0);
                for (s, x) in squares[v][k].iter_mut().zip(&noise) {
                    *s += x * x / PROFILE_DRAWS as f64;
                }
            }
        }
    }
    Ok((0..views.len())
        .map(|v| {
            (0..n)
                .map(|k| {
                    let (floor, rate) = walks[v][k].and(line(&squares[v][k]))?;
                    Some(Profile {
                        floor,
                        rate,
                        slope_error: slopes[v][k].sqrt(),
                    })
                })
                .collect()
        })
        .collect())
}

/// What the draws of noise read: the healthy record, its noise, the views, and the healthy
/// record's estimators' output where it is kept.
type Draws<'a> = (
    &'a Healthy<'a>,
    &'a Replicas<'a>,
    &'a [View],
    Option<&'a Estimated>,
);

/// The residuals, in each view, over the healthy record with the `index`th draw of its
/// noise added, then taken away. With the record's estimators' output kept, the draw alone
/// goes through the estimators, once for both signs: they are linear, so that the sums are,
/// to rounding, what each perturbed record through them gives, for half the cost.
fn pair(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    (healthy, replicas, views, record): Draws<'_>,
    index: usize,
) -> Result<[Vec<Vec<Vec<f64>>>; 2], CalibrateError> {
    let Some(record) = record else {
        let run = |sign: f64| -> Result<_, CalibrateError> {
            let columns = replicas.perturbed(index, sign);
            Ok(healthy.residuals_viewed(build()?, &slices(&columns), views, None))
        };
        return Ok([run(1.0)?, run(-1.0)?]);
    };
    let noise = replicas.noise(index);
    let drawn = build()?.estimated(healthy.samples.time, &slices(&noise));
    let run = |sign: f64| -> Result<_, CalibrateError> {
        let columns: Vec<Vec<f64>> = (healthy.samples.columns.iter().zip(&noise))
            .map(|(x, e)| x.iter().zip(e).map(|(x, e)| x + sign * e).collect())
            .collect();
        let estimated = record.plus(&drawn, sign);
        Ok(healthy.residuals_viewed(build()?, &slices(&columns), views, Some(&estimated)))
    };
    Ok([run(1.0)?, run(-1.0)?])
}

/// The least-squares line `a + b k` through the finite values of `v` (at `k` = 0, 1, ...),
/// each coefficient at least 0.
fn line(v: &[f64]) -> Option<(f64, f64)> {
    let points: Vec<(f64, f64)> = (v.iter().enumerate())
        .filter(|(_, x)| x.is_finite())
        .map(|(k, &x)| (k as f64, x))
        .collect();
    let n = points.len() as f64;
    if n < 3.0 {
        return None;
    }
    let (mk, mv) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (k, x)| (a + k / n, b + x / n));
    let (sxy, sxx) = (points.iter()).fold((0.0, 0.0), |(xy, xx), (k, x)| {
        (xy + (k - mk) * (x - mv), xx + (k - mk) * (k - mk))
    });
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    Some(((mv - slope * mk).max(0.0), slope.max(0.0)))
}

/// Each residual's |series| net of its walk's drift, over its deviation, where it follows one.
fn net_of_drift(mut series: Vec<Vec<f64>>, walks: &[Option<Walk>]) -> Vec<Vec<f64>> {
    for (r, walk) in series.iter_mut().zip(walks) {
        if let Some(w) = walk {
            for (k, v) in r.iter_mut().enumerate() {
                *v = (v.abs() - w.drift * k as f64).max(0.0) / w.deviation(k);
            }
        }
    }
    series
}

/// Each residual's series over its walk's deviation, where it follows one.
fn normalised(mut series: Vec<Vec<f64>>, walks: &[Option<Walk>]) -> Vec<Vec<f64>> {
    for (r, walk) in series.iter_mut().zip(walks) {
        if let Some(w) = walk {
            for (k, v) in r.iter_mut().enumerate() {
                *v /= w.deviation(k);
            }
        }
    }
    series
}

/// Each residual's level (normalised as [`thresholds`] does) that the healthy record's noise,
/// drawn again, makes it exceed with probability `crossing`: the maxima of
/// [`replicas::COUNT`] draws, as a Gumbel law. What the model's error adds along the
/// trajectory is the healthy record's own, which the threshold is at least.
/// Borrowed columns.
fn slices(columns: &[Vec<f64>]) -> Vec<&[f64]> {
    columns.iter().map(Vec::as_slice).collect()
}

fn replica_levels(
    build: &dyn Fn() -> Result<Generator, CalibrateError>,
    draws: Draws<'_>,
    walks: &[Vec<Option<Walk>>],
    crossing: &[f64],
) -> Result<Vec<Vec<Option<f64>>>, CalibrateError> {
    let views = draws.2;
    let mut maxima: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); crossing.len()]; views.len()];
    for index in 0..replicas::COUNT {
        let [up, down] = pair(build, draws, index)?;
        for (((maxima, up), down), walks) in maxima.iter_mut().zip(up).zip(down).zip(walks) {
            let noise = (up.iter().zip(&down))
                .map(|(u, d)| u.iter().zip(d).map(|(u, d)| 0.5 * (u - d)).collect())
                .collect();
            for (m, s) in maxima.iter_mut().zip(normalised(noise, walks)) {
                let finite = s.iter().filter(|v| v.is_finite());
                m.push(finite.fold(0.0, |a, v| a.max(v.abs())));
            }
        }
    }
    Ok(maxima
        .iter()
        .map(|maxima| {
            (maxima.iter().zip(crossing))
                .map(|(m, &crossing)| replicas::gumbel_level(m, crossing))
                .collect()
        })
        .collect())
}

/// The level that a stationary Gaussian residual with the healthy series `s`'s spectrum
/// crosses, on either side, with probability `crossing` over [`Walk::HORIZON`]
/// times `length` samples: by Rice's formula its upcrossings of `c σ` come at
/// `ν₀ e^{−c²/2}` per sample. `ν₀` is read from the series' own excursions past one
/// deviation, each counted once from the mean (a slow residual with a little white noise on
/// it chatters across its mean, not past a deviation). The largest value of one record is an
/// extreme value, which says less of the next record than this does. 0 (no statement) where
/// the record holds too few excursions to tell.
fn rice_level(s: &[f64], length: usize, crossing: f64) -> f64 {
    let finite: Vec<f64> = s.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.len() < 3 {
        return 0.0;
    }
    let mean = finite.iter().sum::<f64>() / finite.len() as f64;
    let var = finite.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / finite.len() as f64;
    if var <= 0.0 {
        return 0.0;
    }
    let sigma = var.sqrt();
    let excursions = excursions(&finite, mean, sigma);
    if excursions < 10 {
        return 0.0;
    }
    // Upcrossings of one deviation on either side, per sample, back to the mean level.
    let rate = excursions as f64 / (2.0 * finite.len() as f64) * 0.5f64.exp();
    let crossings = 2.0 * rate * Walk::HORIZON * length as f64;
    let c = if crossings > crossing {
        (2.0 * (crossings / crossing).ln()).sqrt()
    } else {
        0.0
    };
    mean.abs() + c * sigma
}

/// How many times `s` goes past `mean ± sigma`, each counted once until it is back at the
/// mean.
fn excursions(s: &[f64], mean: f64, sigma: f64) -> usize {
    let mut count = 0;
    // The side of the excursion under way: +1 above, −1 below, 0 none.
    let mut side = 0.0;
    for v in s {
        let d = v - mean;
        if side == 0.0 && d.abs() > sigma {
            count += 1;
            side = d.signum();
        } else if side != 0.0 && d * side <= 0.0 {
            side = 0.0;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_walks_profile_is_the_line_through_its_mean_squares() {
        let v: Vec<f64> = (0..100).map(|k| 2.0 + 0.5 * k as f64).collect();
        let (a, b) = line(&v).expect("a line");
        assert!((a - 2.0).abs() < 1e-9 && (b - 0.5).abs() < 1e-12, "{a} {b}");
        let falling: Vec<f64> = (0..100).map(|k| 10.0 - k as f64).collect();
        assert_eq!(line(&falling).map(|l| l.1), Some(0.0));
        assert_eq!(line(&[1.0, f64::NAN]), None);
    }
}
