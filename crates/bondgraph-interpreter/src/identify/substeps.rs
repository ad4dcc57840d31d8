//! How finely the copy of the model is integrated while a simulation error is fitted or
//! judged: Runge–Kutta steps per sample interval, doubled until the residuals stop changing.
//!
//! The generated code steps its copy once a sample, which holds where the copy's motion is
//! slow against the samples. A resonance at 9 samples per period is not: one step a sample
//! turns its phase by about a radian over a thousand samples, and a fit of the simulation
//! error would move the mass to make up for the integrator's error. A linearisation at rest
//! would not say how fast a hardening spring gets at its amplitude, so the choice is made on
//! the record itself.

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

use crate::fit::Fit;
use crate::generator::Generator;

/// Most steps per sample interval.
pub(crate) const MOST_SUBSTEPS: usize = 64;

/// How far the residuals may move between `n` and `2n` steps, relative to their RMS: the
/// fit then makes up for the integrator's error by at most about that much of a
/// parameter.
const TOLERANCE: f64 = 1e-5;

/// The samples of the first record the choice is made on.
const TRIAL_ROWS: usize = 4096;

/// The steps per sample interval past which the residuals of `program` with the parameters
/// `values` move by less than [`TOLERANCE`] of their RMS over the first samples of a
/// record (`time`, and its raw columns in the program's order): 1 where the program runs no
/// copy.
pub(crate) fn substeps(
    c: &Compiled,
    program: &Program,
    values: &[f64],
    (time, raw): (&[f64], &[&[f64]]),
    fit: &Fit,
) -> usize {
    if program.copy.is_none() || time.is_empty() {
        return 1;
    }
    let rows = time.len().min(TRIAL_ROWS);
    let (time, raw): (&[f64], Vec<&[f64]>) =
        (&time[..rows], raw.iter().map(|c| &c[..rows]).collect());
    let run = |n: usize| -> Option<Vec<f64>> {
        let mut generator = Generator::new(c, program, values, fit)
            .ok()?
            .with_substeps(n);
        let mut out = Vec::new();
        generator.run(time, &raw, false, |estimates| {
            for k in 0..estimates.residual_count() {
                out.extend_from_slice(estimates.residual(k));
            }
        });
        Some(out)
    };
    let Some(mut here) = run(1) else {
        return 1;
    };
    let mut n = 1;
    while n < MOST_SUBSTEPS {
        let Some(finer) = run(2 * n) else {
            return n;
        };
        let finite: Vec<(f64, f64)> = (here.iter().zip(&finer))
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(&a, &b)| (a, b))
            .collect();
        let all = finite.len() == finer.len();
        let rms =
            (finite.iter().map(|(_, b)| b * b).sum::<f64>() / finite.len().max(1) as f64).sqrt();
        let moved = finite.iter().fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        if all && moved <= TOLERANCE * rms.max(f64::MIN_POSITIVE) {
            return n;
        }
        n *= 2;
        here = finer;
    }
    MOST_SUBSTEPS
}
