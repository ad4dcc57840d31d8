//! The model fitted to the healthy record before anything is chosen on it.

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

use crate::calibrate::samples::Samples;
use crate::fit::{Estimator, Fit, Integration};
use crate::identify::{
    identify, Determined, Identification, IdentifyError, Origin, Record, Settings, Span,
};
use crate::relations::Relations;

/// The healthy samples the model is fitted on: a few minutes at the rates benches sample at
/// determine what a record can, and a fit's time grows with them.
const FIT_ROWS: usize = 200_000;

/// The Savitzky–Golay windows the model may be fitted with, the shortest first: the first
/// follows a bench's dynamics at 1 kHz (an equation-error fit's estimates are biased where a
/// longer window smooths a nonlinearity); a longer one is needed where the signals' noise
/// swamps the derivatives' estimates over it (an encoder read in counts, whose speed is a
/// count's difference).
const FIT_WINDOWS: [usize; 4] = [51, 101, 201, 501];

/// How far above the least (over [`FIT_WINDOWS`]) a window's residuals at the model's values
/// may be for it to be taken: an order of magnitude is the noise swamping them, not the
/// model's error, which a shorter window follows better.
const SWAMPED: f64 = 10.0;

/// Why a fit over one window is not taken, and the combinations it found.
struct Refused {
    why: Refusal,
    combined: Vec<Vec<usize>>,
}

/// What was wrong with a fit.
enum Refusal {
    /// It could not be done.
    Failed(IdentifyError),
    /// It moved parameters further than a plant a few percent off its model would.
    Implausible(String),
    /// It ran away with every parameter it could fit, these.
    Lost(Vec<String>),
}

/// The parameters fitted to the healthy record (its first [`FIT_ROWS`] samples), said on
/// standard error: what moved, by how much, and what the record does not determine. Where
/// the fit cannot be done, the model's values, with the reason. Second, the combinations the
/// fit found the parameters determined only in (each by the parameters' places): their
/// values rest on one another's, and a fault's size on them is a ratio only.
///
/// Where simulated residuals sit beside the relations (the bank), the relations alone are
/// fitted (see [`Relations`]).
pub(super) fn fit_model(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    settled: Option<f64>,
    notes: &mut Vec<String>,
) -> (Vec<f64>, Vec<Vec<usize>>) {
    let Some(relations) = Relations::of(c, program) else {
        return fit_program(c, program, params, healthy, settled, notes);
    };
    let samples = Samples {
        time: healthy.time,
        columns: relations.columns(&healthy.columns),
        step: healthy.step,
    };
    let fitted = fit_program(
        &relations.compiled,
        &relations.program,
        params,
        &samples,
        settled,
        notes,
    );
    if let Some(note) = notes.last_mut() {
        note.push_str(
            " (by the relations alone: the simulated residuals run with the values they find)",
        );
    }
    fitted
}

/// [`fit_model`] on the residuals of `program`, whichever they are.
fn fit_program(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    settled: Option<f64>,
    notes: &mut Vec<String>,
) -> (Vec<f64>, Vec<Vec<usize>>) {
    let rows = healthy.len().min(FIT_ROWS);
    let Searched {
        window,
        swamped,
        refused_over,
        fitted,
    } = search(c, program, params, (healthy, rows, settled));
    let found = match fitted {
        Ok(found) => found,
        Err(refused) => {
            let (window, why) = refused_over.unwrap_or((window, refused.why));
            notes.push(format!(
                "thresholds set on the model's values: {} (estimates over {window} samples, \
                 and over each longer window tried)",
                why.said(),
            ));
            return (params.to_vec(), refused.combined);
        }
    };
    let combined: Vec<Vec<usize>> = (found.undetermined.iter())
        .map(|c| c.scalings.iter().map(|&(k, _)| k).collect())
        .collect();
    let mut over = match swamped {
        None => format!("estimates over {window} samples"),
        Some((shortest, ratio)) => format!(
            "estimates over {window} samples: over {shortest}, the residuals at the model's \
             values are {ratio:.0}× the least over any window tried (the signals' noise \
             swamping them), over this one within {SWAMPED}× it"
        ),
    };
    if let Some((shorter, why)) = refused_over {
        over.push_str(&format!(
            "; over {shorter} (and each longer window tried before this one), {}",
            why.said()
        ));
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
    let mut unseen = if hidden.is_empty() {
        String::new()
    } else {
        format!(
            "; {} are determined only in combination (bgc identify says which), and moved \
             only along it",
            hidden.join(", ")
        )
    };
    let lost: Vec<&str> = (found.estimates.iter())
        .filter(|e| e.determined == Determined::Lost)
        .map(|e| e.name.as_str())
        .collect();
    if !lost.is_empty() {
        unseen.push_str(&format!(
            "; {} kept at the model's values, the fit having run them out of all proportion \
             (the record does not hold them), the others fitted without them",
            lost.join(", ")
        ));
    }
    notes.push(format!(
        "the model fitted to it before the thresholds are set ({over}; keeping the model keeps \
         its values; 95 % intervals): {}{unseen}; the residuals' RMS there {}",
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

/// Where the windows were searched to: the window fitted over last, the shortest window's
/// residuals against the least where the search began past it (see [`fit_window`]), the
/// first window whose fit was refused before a longer one was tried, and the last fit.
struct Searched {
    window: usize,
    swamped: Option<(usize, f64)>,
    refused_over: Option<(usize, Refusal)>,
    fitted: Result<Identification, Refused>,
}

/// The model fitted over the window [`fit_window`] chooses; where the record is too short
/// for it, over each shorter one in turn, as a fit over a noisier estimate beats none; where
/// it ran away or moved parameters by factors over noisy estimates, over each longer one in
/// turn, whose noise is less.
fn search(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    (healthy, rows, settled): (&Samples<'_>, usize, Option<f64>),
) -> Searched {
    let (mut window, mut swamped) = fit_window(c, program, params, healthy, rows);
    let mut fitted = fit_over(c, program, params, (healthy, rows, settled), window);
    // Too short for a window's fit: shorter ones.
    while let Err(Refused {
        why: Refusal::Failed(IdentifyError::TooShort { .. }),
        ..
    }) = fitted
    {
        let Some(&shorter) = FIT_WINDOWS.iter().rev().find(|&&w| w < window) else {
            break;
        };
        window = shorter;
        swamped = swamped.filter(|&(shortest, _)| shortest < window);
        fitted = fit_over(c, program, params, (healthy, rows, settled), window);
    }
    // Run away or implausible: longer ones.
    let mut refused_over = None;
    while let Err(refused) = &fitted {
        if matches!(refused.why, Refusal::Failed(_)) {
            break;
        }
        let Some(&longer) = (FIT_WINDOWS.iter()).find(|&&w| w > window && w <= longest(rows))
        else {
            break;
        };
        let again = fit_over(c, program, params, (healthy, rows, settled), longer);
        if let Err(first) = std::mem::replace(&mut fitted, again) {
            refused_over.get_or_insert((window, first.why));
        }
        window = longer;
    }
    Searched {
        window,
        swamped,
        refused_over,
        fitted,
    }
}

/// The window the model is fitted over, on the first `rows` samples of `healthy`: the
/// shortest of [`FIT_WINDOWS`] (at most a twentieth of them) whose residuals at the model's
/// values are within [`SWAMPED`] of the least, each residual by the median of its magnitude
/// (which a start-up or an input's steps do not move). Second, where it is not the shortest,
/// the shortest and how many times its residuals are the least (the largest ratio over the
/// residuals).
fn fit_window(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    rows: usize,
) -> (usize, Option<(usize, f64)>) {
    let mut windows: Vec<usize> = FIT_WINDOWS.iter().map(|&w| w.min(longest(rows))).collect();
    windows.dedup();
    let medians: Vec<Option<Vec<f64>>> = (windows.iter())
        .map(|&w| {
            medians(
                c,
                program,
                params,
                healthy,
                rows,
                &settings_fit(c, program, healthy, w),
            )
        })
        .collect();
    let least: Vec<f64> = (0..c.arrs.len())
        .map(|k| {
            (medians.iter().flatten())
                .map(|m| m[k])
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let quiet = |m: &Vec<f64>| m.iter().zip(&least).all(|(a, b)| *a <= SWAMPED * b);
    let Some(at) = medians.iter().position(|m| m.as_ref().is_some_and(quiet)) else {
        return (windows[0], None);
    };
    if at == 0 {
        return (windows[0], None);
    }
    let ratio = match &medians[0] {
        Some(first) => (first.iter().zip(&least))
            .map(|(a, b)| a / b)
            .fold(0.0, f64::max),
        None => f64::INFINITY,
    };
    (windows[at], Some((windows[0], ratio)))
}

/// The longest window a fit over `rows` samples may take: a twentieth of them.
fn longest(rows: usize) -> usize {
    ((rows / 20) | 1).max(11)
}

/// Each residual's median magnitude over the first `rows` samples, the model at `params`
/// and estimated as `fit` says; `None` where the generator cannot be built or a residual is
/// never a number.
fn medians(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    healthy: &Samples<'_>,
    rows: usize,
    fit: &Fit,
) -> Option<Vec<f64>> {
    let mut generator = crate::generator::Generator::new(c, program, params, fit).ok()?;
    let raw: Vec<&[f64]> = healthy.columns.iter().map(|c| &c[..rows]).collect();
    let mut series: Vec<Vec<f64>> = vec![Vec::new(); c.arrs.len()];
    generator.run(&healthy.time[..rows], &raw, false, |e| {
        for (k, s) in series.iter_mut().enumerate().take(e.residual_count()) {
            s.extend(
                e.residual(k)
                    .iter()
                    .filter(|v| v.is_finite())
                    .map(|v| v.abs()),
            );
        }
    });
    (series.into_iter())
        .map(|mut s| (!s.is_empty()).then(|| crate::deviation::median_abs(&mut s)))
        .collect()
}

/// How the model is fitted over `window`-sample estimates.
fn settings_fit(c: &Compiled, program: &Program, healthy: &Samples<'_>, window: usize) -> Fit {
    Fit {
        step: healthy.step,
        estimator: Estimator::SavitzkyGolay {
            window,
            degree: program.top_order().max(3),
        },
        integration: vec![Integration::default(); c.arrs.len()],
    }
}

/// The model fitted over `window`-sample estimates to the first `rows` samples of the
/// healthy record (from where it has `settled`), or why that fit is not to be taken.
fn fit_over(
    c: &Compiled,
    program: &Program,
    params: &[f64],
    (healthy, rows, settled): (&Samples<'_>, usize, Option<f64>),
    window: usize,
) -> Result<Identification, Refused> {
    let settings = Settings {
        fit: settings_fit(c, program, healthy, window),
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
    let found = identify(c, program, params, &[record], &settings).map_err(|e| Refused {
        why: Refusal::Failed(e),
        combined: Vec::new(),
    })?;
    let combined: Vec<Vec<usize>> = (found.undetermined.iter())
        .map(|c| c.scalings.iter().map(|&(k, _)| k).collect())
        .collect();
    let names: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
    if let Some(why) = implausible(params, &found.values, (&names, &found.rms)) {
        return Err(Refused {
            why: Refusal::Implausible(why),
            combined,
        });
    }
    let fitted = (found.estimates.iter()).any(|e| {
        matches!(
            e.determined,
            Determined::Yes | Determined::Weakly | Determined::No
        )
    });
    if !found.lost.is_empty() && !fitted {
        let lost = (found.lost.iter())
            .map(|l| found.estimates[l.parameter].name.clone())
            .collect();
        return Err(Refused {
            why: Refusal::Lost(lost),
            combined,
        });
    }
    Ok(found)
}

impl Refusal {
    /// What the note says of it.
    fn said(&self) -> String {
        match self {
            Refusal::Failed(e) => {
                format!("they could not be fitted to the healthy record ({e})")
            }
            Refusal::Implausible(why) => format!(
                "fitted to the healthy record, {why}, which says the record does not \
                 determine them (bgc identify says which) or the model is not the plant, not \
                 that the plant is a few percent off it"
            ),
            Refusal::Lost(names) => format!(
                "the fit ran away with every parameter, {} (out of all proportion to the model's values: the \
                 record does not hold them over such estimates)",
                names.join(", ")
            ),
        }
    }
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
