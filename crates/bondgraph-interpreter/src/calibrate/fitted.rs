//! The model fitted to the healthy record before anything is chosen on it.

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

use crate::calibrate::samples::Samples;
use crate::fit::{Estimator, Fit, Integration};
use crate::identify::{identify, Determined, Origin, Record, Settings, Span};

/// The healthy samples the model is fitted on: a few minutes at the rates benches sample at
/// determine what a record can, and a fit's time grows with them.
const FIT_ROWS: usize = 200_000;

/// The Savitzky–Golay window the model is fitted with: long enough that the noise of the
/// estimates is far below the signals', short enough to follow a bench's dynamics at 1 kHz.
const FIT_WINDOW: usize = 51;

/// The parameters fitted to the healthy record (its first [`FIT_ROWS`] samples), said on
/// standard error: what moved, by how much, and what the record does not determine. Where
/// the fit cannot be done, the model's values, with the reason. Second, the combinations the
/// fit found the parameters determined only in (each by the parameters' places): their
/// values rest on one another's, and a fault's size on them is a ratio only.
pub(super) fn fit_model(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    settled: Option<f64>,
    notes: &mut Vec<String>,
) -> (Vec<f64>, Vec<Vec<usize>>) {
    let rows = healthy.len().min(FIT_ROWS);
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
        // A record that starts singular (at rest) is fitted from where it has settled.
        span: settled
            .filter(|&t| t < healthy.time[rows - 1])
            .map(|from| Span {
                from,
                to: healthy.time[rows - 1],
                origin: Origin::Span,
            }),
    };
    let record = Record {
        time: &healthy.time[..rows],
        raw: healthy.columns.iter().map(|c| &c[..rows]).collect(),
        state: None,
    };
    let found = match identify(c, program, params, &[record], &settings) {
        Ok(found) => found,
        Err(e) => {
            notes.push(format!(
                "thresholds set on the model's values, which could not be fitted to the \
                 healthy record ({e})"
            ));
            return (params.to_vec(), Vec::new());
        }
    };
    let combined: Vec<Vec<usize>> = (found.undetermined.iter())
        .map(|c| c.scalings.iter().map(|&(k, _)| k).collect())
        .collect();
    let names: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
    if let Some(why) = implausible(params, &found.values, (&names, &found.rms)) {
        notes.push(format!(
            "thresholds set on the model's values: fitted to the healthy record, {why}, which \
             says the record does not determine them (bgc identify says which) or the model \
             is not the plant, not that the plant is a few percent off it"
        ));
        return (params.to_vec(), combined);
    }
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
    notes.push(format!(
        "the model fitted to it before the thresholds are set (keeping the model keeps its \
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
    (found.values, combined)
}

/// How far a calibration's fit may move a parameter, as a factor either way: it is there to
/// take up a plant a few percent off its model; a larger change is a fault, or a fit gone
/// along what the record does not determine.
const PLAUSIBLE: f64 = 2.0;

/// Why a fit is not to be taken: a residual that is no longer a number or vanishes
/// altogether (a relation scaled away), or a parameter moved by more than [`PLAUSIBLE`] or
/// across zero. `None` where it is to be.
fn implausible(
    model: &[f64],
    fitted: &[f64],
    (names, rms): (&[&str], &[(f64, f64)]),
) -> Option<String> {
    if let Some(k) = rms
        .iter()
        .position(|(_, after)| !(after.is_finite() && *after > 0.0))
    {
        return Some(format!("{}'s RMS would be {}", names[k], rms[k].1));
    }
    let far = |(a, b): (&f64, &f64)| {
        let ratio = b / a;
        *a != 0.0 && !(ratio.is_finite() && (1.0 / PLAUSIBLE..=PLAUSIBLE).contains(&ratio))
    };
    let moved = model.iter().zip(fitted).filter(|&p| far(p)).count();
    (moved > 0).then(|| {
        format!("{moved} parameter(s) would move by more than a factor {PLAUSIBLE} or change sign")
    })
}
