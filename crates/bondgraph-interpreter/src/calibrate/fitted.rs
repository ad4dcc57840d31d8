//! The model fitted to the healthy record before anything is chosen on it.

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

use crate::calibrate::Samples;
use crate::fit::{Estimator, Fit, Integration};
use crate::identify::{identify, Determined, Record, Settings};

/// The healthy samples the model is fitted on: a few minutes at the rates benches sample at
/// determine what a record can, and a fit's time grows with them.
const FIT_ROWS: usize = 200_000;

/// The Savitzky–Golay window the model is fitted with: long enough that the noise of the
/// estimates is far below the signals', short enough to follow a bench's dynamics at 1 kHz.
const FIT_WINDOW: usize = 51;

/// The parameters fitted to the healthy record (its first [`FIT_ROWS`] samples), said on
/// standard error: what moved, by how much, and what the record does not determine. Where
/// the fit cannot be done, the model's values, with the reason.
pub(super) fn fit_model(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    notes: &mut Vec<String>,
) -> Vec<f64> {
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
        span: None,
    };
    let record = Record {
        time: &healthy.time[..rows],
        raw: healthy.columns.iter().map(|c| &c[..rows]).collect(),
    };
    let found = match identify(c, program, params, &[record], &settings) {
        Ok(found) => found,
        Err(e) => {
            notes.push(format!(
                "thresholds set on the model's values, which could not be fitted to the \
                 healthy record ({e})"
            ));
            return params.to_vec();
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
    found.values
}
