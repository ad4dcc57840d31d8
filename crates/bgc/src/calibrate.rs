//! `bgc residuals --calibrate`: the estimator window, each integrated residual's integration
//! and each residual's threshold, chosen from a healthy record.

use bondgraph::Reference;

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;
use bondgraph_interpreter::{
    identify, Determined, Estimator, Fit, Generator, Integration, Record, Settings, Walk,
};

use crate::record::Data;
use crate::replicas::{self, Replicas};
use crate::report::{self, Failure};

/// The healthy samples the model is fitted on: a few minutes at the rates benches sample at
/// determine what a record can, and a fit's time grows with them.
const FIT_ROWS: usize = 200_000;

/// The Savitzky–Golay window the model is fitted with: long enough that the noise of the
/// estimates is far below the signals', short enough to follow a bench's dynamics at 1 kHz.
const FIT_WINDOW: usize = 51;

/// The parameters fitted to the healthy record (its first [`FIT_ROWS`] samples), said on
/// standard error: what moved, by how much, and what the record does not determine. Where
/// the fit cannot be done, the model's values, with the reason.
pub(crate) fn fit_model(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Data,
    name: &str,
) -> Result<Vec<f64>, Failure> {
    let rows = healthy.time.len().min(FIT_ROWS);
    let window = FIT_WINDOW.min((rows / 20) | 1).max(11);
    let settings = Settings {
        fit: Fit {
            step: healthy.step,
            estimator: Estimator::SavitzkyGolay {
                window,
                degree: program.top_order().max(3),
            },
            integration: vec![Integration::default(); c.arrs.len()],
        },
        free: Vec::new(),
        bounded: false,
        span: None,
    };
    let record = Record {
        time: &healthy.time[..rows],
        raw: healthy.columns.iter().map(|c| &c[..rows]).collect(),
    };
    let found = match identify(c, program, params, &[record], &settings) {
        Ok(found) => found,
        Err(e) => {
            report::note(format!(
                "{name}: thresholds set on the model's values, which could not be fitted to \
                 it ({e}); --keep-model says so"
            ));
            return Ok(params.to_vec());
        }
    };
    let moved: Vec<String> = (found.estimates.iter())
        .filter(|e| matches!(e.determined, Determined::Yes | Determined::Weakly))
        .filter(|e| (e.value - e.start).abs() > e.half_width)
        .map(|e| {
            let change = if e.start == 0.0 {
                String::new()
            } else {
                format!(" ({:+.2} %)", 100.0 * (e.value / e.start - 1.0))
            };
            format!(
                "{} {} -> {} ± {:.2e}{change}",
                e.name, e.start, e.value, e.half_width
            )
        })
        .collect();
    let hidden = (found.estimates.iter())
        .filter(|e| e.determined == Determined::No)
        .map(|e| e.name.as_str())
        .collect::<Vec<_>>();
    let unseen = if hidden.is_empty() {
        String::new()
    } else {
        format!(
            "; {} are determined only in combination (bgc identify says which), and moved \
             only along it",
            hidden.join(", ")
        )
    };
    report::note(format!(
        "{name}: the model fitted to it before the thresholds are set (--keep-model keeps its \
         values; 95 % intervals): {}{unseen}; the residuals' RMS there {}",
        if moved.is_empty() {
            "no parameter moved beyond its interval".to_string()
        } else {
            moved.join(", ")
        },
        (c.arrs.iter().zip(&found.rms))
            .map(|(a, (b, f))| format!("{} {:.3e} -> {:.3e}", a.name, b, f))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    Ok(found.values)
}

/// The Savitzky–Golay windows `--calibrate` chooses from, shortest first.
pub(crate) const WINDOWS: [usize; 6] = [11, 21, 51, 101, 201, 501];

/// The integration windows `--calibrate` chooses from, shortest first.
pub(crate) const INTEGRATIONS: [usize; 5] = [Reference::DEFAULT_WINDOW, 1000, 2500, 10_000, 25_000];

/// The longest window of [`WINDOWS`] (at most a tenth of the healthy record) up to which no
/// residual's RMS on it grows: a longer window averages more noise away until its polynomial
/// no longer follows the signals somewhere, which the residual that reads them shows first.
/// Stopping there rather than at the least overall noise keeps a margin for a faulty record,
/// whose signals are less smooth than the healthy one's (on the bench's dead-zone scenario, the
/// window of least noise, 501 samples, had ARR1 alarm at the load's stalls, which ARR2 alone
/// should show).
pub(crate) fn longest_steady_window(
    build: &dyn Fn(usize) -> Result<Generator, Failure>,
    healthy: &Data,
) -> Result<usize, Failure> {
    let longest = (healthy.time.len() / 10).max(WINDOWS[0]);
    let mut chosen: Option<(usize, Vec<f64>)> = None;
    for &window in WINDOWS.iter().filter(|&&w| w <= longest) {
        let now: Vec<f64> = residuals(build(window)?, healthy)
            .iter()
            .map(|r| rms(r))
            .collect();
        if let Some((_, before)) = &chosen {
            if now.iter().zip(before).any(|(n, b)| n > b) {
                break;
            }
        }
        chosen = Some((window, now));
    }
    Ok(chosen.map_or(WINDOWS[0], |(w, _)| w))
}

/// The modulating functions' window when neither `--window` nor `--calibrate` gives one.
pub(crate) const MODULATING_DEFAULT: usize = 101;

/// The windows of modulating functions `--calibrate` chooses from for a healthy record, for a
/// program that reads derivatives up to `top`: from 21 samples to a quarter of the record,
/// each holding the function (more than twice its smoothness, `top + 1`). Longer than the
/// polynomial fits' (a tenth): on ARRs linear in the signals they carry no fit error, only
/// the time a fault takes to show.
pub(crate) fn modulating_windows(healthy: &Data, top: u32) -> impl Iterator<Item = usize> {
    let longest = healthy.time.len() / 4;
    let shortest = 2 * (top as usize + 1) + 1;
    [21, 51, 101, 201, 501, 1001, 2001, 5001]
        .into_iter()
        .filter(move |&w| w <= longest && w > shortest)
}

/// A generator with an estimator and parameters of the caller's choice.
pub(crate) type BuildWith<'a> = dyn Fn(Estimator, &[f64]) -> Result<Generator, Failure> + 'a;

/// How far a parameter is moved to see what the residuals make of a fault of it.
const PERTURBATION: f64 = 0.2;

/// The estimator of `candidates` under whose thresholds (as [`thresholds`] calibrates them,
/// with no false alarm allowed) a fault of a fifth of a parameter moves the residuals most,
/// for the parameter they see least, then for the parameters' geometric mean: the hardest
/// fault decides, as it is the one an estimator can lose. A fault's move is the RMS change
/// of the residual that shows it best, in thresholds, with the residuals evaluated on the
/// healthy record with that parameter moved: to first order, what the fault adds. With
/// what was measured, for the note.
pub(crate) fn most_sensitive(
    build: &BuildWith<'_>,
    healthy: &Data,
    candidates: &[Estimator],
    params: &[f64],
    margin: f64,
) -> Result<(Estimator, String), Failure> {
    let mut best: Option<((f64, f64), Estimator)> = None;
    let mut said = Vec::new();
    for &estimator in candidates {
        let nominal = residuals(build(estimator, params)?, healthy);
        let none = vec![None; nominal.len()];
        let levels = thresholds(
            &|| build(estimator, params),
            healthy,
            &none,
            0.0,
            margin,
            None,
            Walk::CROSSING,
        )?;
        let mut moves = Vec::new();
        for k in (0..params.len()).filter(|&k| params[k] != 0.0) {
            let mut moved = params.to_vec();
            moved[k] *= 1.0 + PERTURBATION;
            let series = residuals(build(estimator, &moved)?, healthy);
            // A parameter no residual reads moves none under any estimator.
            if series == nominal {
                continue;
            }
            let shown = (series.iter().zip(&nominal).zip(&levels))
                .map(|((s, n), &level)| {
                    let change: Vec<f64> = s.iter().zip(n).map(|(a, b)| a - b).collect();
                    rms(&change) / level.max(f64::MIN_POSITIVE)
                })
                .fold(0.0, f64::max);
            moves.push(shown);
        }
        // No parameter read: nothing to tell the candidates apart by, the first stays.
        let (least, typical) = match moves.is_empty() {
            true => (0.0, 0.0),
            false => (
                moves.iter().copied().fold(f64::INFINITY, f64::min),
                (moves
                    .iter()
                    .map(|m| m.max(f64::MIN_POSITIVE).ln())
                    .sum::<f64>()
                    / moves.len() as f64)
                    .exp(),
            ),
        };
        said.push(format!(
            "{}: {} at least, {} typically",
            describe(estimator),
            significant(least),
            significant(typical)
        ));
        if best.is_none_or(|(b, _)| (least, typical) > b) {
            best = Some(((least, typical), estimator));
        }
    }
    let chosen = best.map_or(candidates[0], |(_, e)| e);
    Ok((chosen, said.join(", ")))
}

/// `x` to two significant digits.
fn significant(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let digits = (1 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

/// An estimator as the notes name it.
fn describe(e: Estimator) -> String {
    match e {
        Estimator::SavitzkyGolay { window, .. } => format!("fits over {window} samples"),
        Estimator::Modulating { window } => format!("modulating functions over {window} samples"),
    }
}

/// Each integrated residual's integration: a window of [`INTEGRATIONS`] (at most a twentieth
/// of the healthy record) or from the start, whichever has the largest ratio of its length to
/// the residual's noise on it; and for those taken from the start, their noise's [`Walk`].
///
/// A fault that moves a relation for as long as it lasts moves its integral in proportion to
/// the length, while the noise grows as its square root or less, and a model error as the
/// length itself. A longer window must gain a tenth to be chosen: it also takes longer to show
/// a fault, and its noise is known from fewer independent stretches.
///
/// From the start counts as the whole record's length against the noise at its end, and is a
/// candidate only where the residual's noise fits a [`Walk`]: its threshold then grows with
/// the walk's deviation, so that it holds on a record of another seed or length. On a record
/// too short to tell a walk from a drift it is never chosen (on the Table 3 bench's 3-s
/// records, a constant threshold from one record gave 1,316 false alarms of 2,800 samples on
/// another). Where it is (the bench's ARR2 is the derivative of the link's law, so from the
/// start it is that law, with the twist integrated from the encoders), a fault that shows only
/// while a signal moves keeps the residual offset for as long as the fault lasts.
pub(crate) fn longest_integration(
    build: &dyn Fn(Integration) -> Result<Generator, Failure>,
    healthy: &Data,
    integrated: &[bool],
    window: usize,
) -> Result<Vec<(Integration, Option<Walk>)>, Failure> {
    let rows = healthy.time.len();
    let windows = (INTEGRATIONS.iter())
        .filter(|&&n| n <= (rows / 20).max(INTEGRATIONS[0]))
        .map(|&n| Integration::Window(n));
    let candidates = windows.chain([Integration::Start]);
    let mut best: Vec<Option<(f64, Integration, Option<Walk>)>> = vec![None; integrated.len()];
    for candidate in candidates {
        let series = residuals(build(candidate)?, healthy);
        for ((best, r), &integrated) in best.iter_mut().zip(&series).zip(integrated) {
            let (score, walk) = match candidate {
                Integration::Window(n) => ((n as f64 / rms(r)).ln(), None),
                Integration::Start => match Walk::fit(r, window) {
                    Some(w) => ((r.len() as f64 / w.deviation(r.len())).ln(), Some(w)),
                    None => continue,
                },
            };
            if integrated && best.is_none_or(|(b, ..)| score > b + 0.1f64.ln_1p()) {
                *best = Some((score, candidate, walk));
            }
        }
    }
    Ok(best
        .into_iter()
        .map(|b| b.map_or((Integration::default(), None), |(_, i, w)| (i, w)))
        .collect())
}

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
/// (see [`crate::replicas`]) where the record has noise to read, else from the walk's or the
/// record's own excursions.
pub(crate) fn thresholds(
    build: &dyn Fn() -> Result<Generator, Failure>,
    healthy: &Data,
    walks: &[Option<Walk>],
    rate: f64,
    margin: f64,
    replicas: Option<&Replicas<'_>>,
    crossing: f64,
) -> Result<Vec<f64>, Failure> {
    let series = normalised(residuals(build()?, healthy), walks);
    let length = healthy.time.len();
    let replicated = match replicas.filter(|_| rate == 0.0) {
        Some(replicas) => replica_levels(build, replicas, walks, crossing)?,
        None => vec![None; walks.len()],
    };
    Ok((series.into_iter().zip(walks).zip(replicated))
        .map(|((s, walk), replicated)| {
            // A residual that is not a number somewhere (singular at rest) says nothing
            // there: the quantile is that of the samples where it is one.
            let stated = replicated.unwrap_or_else(|| match walk {
                Some(walk) if walk.rate > 0.0 => walk.crossing_level(length, crossing),
                _ => rice_level(&s, length, crossing),
            });
            let mut s: Vec<f64> = s
                .into_iter()
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
        .collect())
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
fn replica_levels(
    build: &dyn Fn() -> Result<Generator, Failure>,
    replicas: &Replicas<'_>,
    walks: &[Option<Walk>],
    crossing: f64,
) -> Result<Vec<Option<f64>>, Failure> {
    let mut maxima: Vec<Vec<f64>> = vec![Vec::new(); walks.len()];
    for index in 0..replicas::COUNT {
        let up = residuals(build()?, &replicas.perturbed(index, 1.0));
        let down = residuals(build()?, &replicas.perturbed(index, -1.0));
        let noise = (up.iter().zip(&down))
            .map(|(u, d)| u.iter().zip(d).map(|(u, d)| 0.5 * (u - d)).collect())
            .collect();
        for (m, s) in maxima.iter_mut().zip(normalised(noise, walks)) {
            let finite = s.iter().filter(|v| v.is_finite());
            m.push(finite.fold(0.0, |a, v| a.max(v.abs())));
        }
    }
    Ok((maxima.iter())
        .map(|m| replicas::gumbel_level(m, crossing))
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

/// A series' RMS (at least the smallest positive number), over its finite values.
fn rms(r: &[f64]) -> f64 {
    let (sum, n) =
        (r.iter().filter(|v| v.is_finite())).fold((0.0, 0), |(s, n), v| (s + v * v, n + 1));
    (sum / (n as f64).max(1.0)).sqrt().max(f64::MIN_POSITIVE)
}

/// Each residual's values over a record, one per estimate.
fn residuals(mut generator: Generator, record: &Data) -> Vec<Vec<f64>> {
    let mut series: Vec<Vec<f64>> = Vec::new();
    let raw: Vec<&[f64]> = record.columns.iter().map(Vec::as_slice).collect();
    generator.run(&record.time, &raw, false, |e| {
        if !e.is_empty() {
            series.resize(e.residual_count(), Vec::new());
        }
        for (k, s) in series.iter_mut().enumerate() {
            s.extend_from_slice(e.residual(k));
        }
    });
    series
}
