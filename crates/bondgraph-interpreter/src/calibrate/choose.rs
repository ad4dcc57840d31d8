//! The choices a calibration makes on a healthy record: the estimator's window and kind,
//! each integrated residual's integration.

use bondgraph::Reference;

use crate::calibrate::error::CalibrateError;
use crate::calibrate::levels::thresholds;
use crate::calibrate::samples::{rms, Healthy};
use crate::fit::{Estimator, Integration};
use crate::generator::Generator;
use crate::walk::{slope, Walk};

/// The Savitzky–Golay windows `--calibrate` chooses from, shortest first.
pub const WINDOWS: [usize; 6] = [11, 21, 51, 101, 201, 501];

/// The integration windows `--calibrate` chooses from, shortest first.
pub const INTEGRATIONS: [usize; 5] = [Reference::DEFAULT_WINDOW, 1000, 2500, 10_000, 25_000];

/// The longest window of [`WINDOWS`] (at most a tenth of the healthy record) up to which no
/// residual's RMS on it grows: a longer window averages more noise away until its polynomial
/// no longer follows the signals somewhere, which the residual that reads them shows first.
/// Stopping there rather than at the least overall noise keeps a margin for a faulty record,
/// whose signals are less smooth than the healthy one's (on the bench's dead-zone scenario, the
/// window of least noise, 501 samples, had ARR1 alarm at the load's stalls, which ARR2 alone
/// should show). Only the residuals that read estimates (`estimated`) decide: a simulated
/// residual reads none, and its RMS moves with the window by the samples at its ends alone,
/// which stopped the bank's relations at 51 samples where alone they took 201.
pub(super) fn longest_steady_window(
    build: &dyn Fn(usize) -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    estimated: &[bool],
) -> Result<usize, CalibrateError> {
    let longest = (healthy.len() / 10).max(WINDOWS[0]);
    let mut chosen: Option<(usize, Vec<f64>)> = None;
    for &window in WINDOWS.iter().filter(|&&w| w <= longest) {
        let now: Vec<f64> = healthy
            .residuals(build(window)?)
            .iter()
            .map(|r| rms(r))
            .collect();
        if let Some((_, before)) = &chosen {
            let grows = (now.iter().zip(before).zip(estimated)).any(|((n, b), &e)| e && n > b);
            if grows {
                break;
            }
        }
        chosen = Some((window, now));
    }
    Ok(chosen.map_or(WINDOWS[0], |(w, _)| w))
}

/// The modulating functions' window when neither `--window` nor `--calibrate` gives one.
pub const MODULATING_DEFAULT: usize = 101;

/// The windows of modulating functions `--calibrate` chooses from for a healthy record, for a
/// program that reads derivatives up to `top`: from 21 samples to a quarter of the record,
/// each holding the function (more than twice its smoothness, `top + 1`). Longer than the
/// polynomial fits' (a tenth): on ARRs linear in the signals they carry no fit error, only
/// the time a fault takes to show.
pub(super) fn modulating_windows(healthy: &Healthy<'_>, top: u32) -> impl Iterator<Item = usize> {
    let longest = healthy.len() / 4;
    let shortest = 2 * (top as usize + 1) + 1;
    [21, 51, 101, 201, 501, 1001, 2001, 5001]
        .into_iter()
        .filter(move |&w| w <= longest && w > shortest)
}

/// A generator with an estimator and parameters of the caller's choice.
pub(super) type BuildWith<'a> = dyn Fn(Estimator, &[f64]) -> Result<Generator, CalibrateError> + 'a;

/// How far a parameter is moved to see what the residuals make of a fault of it.
const PERTURBATION: f64 = 0.2;

/// The estimator of `candidates` under whose thresholds (as [`thresholds`] calibrates them,
/// with no false alarm allowed) a fault of a fifth of a parameter moves the residuals most,
/// for the parameter they see least, then for the parameters' geometric mean: the hardest
/// fault decides, as it is the one an estimator can lose. A fault's move is the RMS change
/// of the residual that shows it best, in thresholds, with the residuals evaluated on the
/// healthy record with that parameter moved: to first order, what the fault adds. With
/// what was measured, for the note.
pub(super) fn most_sensitive(
    build: &BuildWith<'_>,
    healthy: &Healthy<'_>,
    candidates: &[Estimator],
    params: &[f64],
    margin: f64,
) -> Result<(Estimator, String), CalibrateError> {
    let mut best: Option<((f64, f64), Estimator)> = None;
    let mut said = Vec::new();
    for &estimator in candidates {
        let nominal = healthy.residuals(build(estimator, params)?);
        let mut none = vec![None; nominal.len()];
        let levels = thresholds(
            &|| build(estimator, params),
            healthy,
            &mut none,
            (0.0, margin),
            None,
            &vec![Walk::CROSSING; nominal.len()],
        )?;
        let mut moves = Vec::new();
        for k in (0..params.len()).filter(|&k| params[k] != 0.0) {
            let mut moved = params.to_vec();
            moved[k] *= 1.0 + PERTURBATION;
            let series = healthy.residuals(build(estimator, &moved)?);
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

/// The windows of integration calibration chooses from on a healthy record of `rows`
/// samples for faults to show `within` samples after them: [`INTEGRATIONS`] and `within`
/// itself, shortest first, each at most a twentieth of the record (the shortest always).
pub(super) fn integration_lengths(rows: usize, within: usize) -> Vec<usize> {
    let longest = (rows / 20).max(INTEGRATIONS[0]);
    let mut lengths: Vec<usize> = INTEGRATIONS.to_vec();
    lengths.push(within.max(INTEGRATIONS[0]));
    lengths.sort_unstable();
    lengths.dedup();
    lengths.retain(|&n| n <= longest);
    lengths
}

/// Each integrated residual's integration, chosen by the margin a fault gets under its
/// threshold `within` samples after it: a window of [`INTEGRATIONS`] or of `within` samples
/// (at most a twentieth of the healthy record), or from the start; and for those taken from
/// the start, their noise's [`Walk`].
///
/// A fault that moves a relation by `δ` for as long as it lasts moves its integral over a
/// window of `n` samples by `δ min(n, τ)`, `τ` samples after it: over the second half of
/// `within`, by `δ min(n, ¾ within)` at its middle. Against that, the residual's noise on the
/// healthy record (its RMS, which holds the model's error integrated over the window as well
/// as the noise's walk), or, from the start, its walk's deviation at the record's end plus
/// the drift it shows there: a threshold from the start grows with the record, so that the
/// longer the record monitored, the less a fault at its end moves it in thresholds (on the
/// bench with a square input, `Re` × 1.5 moved ARR1 by 31 thresholds 1 to 2 s after it from
/// the start, and by 148 over 2,500 samples). A longer window must gain a tenth to be
/// chosen: its noise is known from fewer independent stretches.
///
/// From the start is a candidate only where the residual's noise fits a [`Walk`]; on a
/// record too short to tell a walk from a drift it is never chosen (on the Table 3 bench's
/// 3-s records, a constant threshold from one record gave 1,316 false alarms of 2,800
/// samples on another).
///
/// `within` `None`: for a fault that persists, over the healthy record's length, among the
/// windows only. From the start, such a residual carries a record's start-up in its
/// integral, which the healthy record's start, left out of calibration, does not price:
/// chosen so on the two-mass drive, its hold raised 57 samples of alarm at 0.034 s.
pub(super) fn best_integration(
    build: &dyn Fn(Integration) -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    integrated: &[bool],
    window: usize,
    within: Option<usize>,
) -> Result<Vec<(Integration, Option<Walk>)>, CalibrateError> {
    let reach = within.unwrap_or(healthy.len());
    let windows = (integration_lengths(healthy.len(), reach).into_iter()).map(Integration::Window);
    let start = within.map(|_| Integration::Start);
    let candidates = windows.chain(start);
    let shown = 0.75 * reach.max(1) as f64;
    let mut best: Vec<Option<(f64, Integration, Option<Walk>)>> = vec![None; integrated.len()];
    for candidate in candidates {
        let series = healthy.residuals(build(candidate)?);
        for ((best, r), &integrated) in best.iter_mut().zip(&series).zip(integrated) {
            let (score, walk) = match candidate {
                Integration::Window(n) => ((n as f64).min(shown) / rms(r), None),
                Integration::Start => match Walk::fit(r, window) {
                    Some(w) => {
                        let noise = w.deviation(r.len()) + slope(r, 0) * r.len() as f64;
                        (shown / noise, Some(w))
                    }
                    None => continue,
                },
            };
            let better = |b: f64| score.ln() > b.ln() + 0.1f64.ln_1p();
            if integrated && score.is_finite() && best.is_none_or(|(b, ..)| better(b)) {
                *best = Some((score, candidate, walk));
            }
        }
    }
    Ok(best
        .into_iter()
        .map(|b| b.map_or((Integration::default(), None), |(_, i, w)| (i, w)))
        .collect())
}
