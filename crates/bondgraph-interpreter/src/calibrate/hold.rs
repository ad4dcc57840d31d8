//! Each integrated residual's two tests, chosen on the healthy record: a short window for
//! onsets and ends, and a hold (see [`crate::hold`]) for faults that persist.

use bondgraph_core::Arr;

use crate::calibrate::error::CalibrateError;
use crate::calibrate::samples::Healthy;
use crate::fit::Integration;
use crate::generator::Generator;
use crate::walk::Walk;

/// The onset window is this fraction of the estimators' window: the estimates already spread
/// a fault over theirs, so a window a quarter as long adds little to when an alarm starts and
/// ends, where a longer one holds an intermittent fault past its end (on EMPS's pulses of
/// 0.5 s, with estimates over 51 samples: 3.1 % of the samples between pulses in alarm over
/// 11 samples, 5.0 % over 25, 9.4 % over 51, 96 % over the 1,000 that gave the most margin
/// from 1 s to 2 s after a fault).
const ONSET_SHARE: usize = 4;

/// A hold as chosen, before its level: its reach, whether anchored, its walk.
pub(super) type HeldBy = (Integration, bool, Option<Walk>);

/// The onset window, in samples, for estimates over `window` samples.
pub(super) fn onset_window(window: usize) -> usize {
    (window / ONSET_SHARE).max(1)
}

/// Whether a relation reads a signal integrated from the start (the bench's twist): its own
/// integral from the start is then the balance that the integral read belongs to.
pub(super) fn anchored(arr: &Arr) -> bool {
    arr.reads.iter().any(|r| r.integral) || !arr.integrals.is_empty()
}

/// What holds each integrated residual: from the start where it is anchored and its noise
/// there is a walk; else the reach `best` gave it (the most margin for a fault that
/// persists, or `within` after a fault where that is given),
/// restarted at the end of the onset alarms that raise it, where it reaches further than
/// the onset window. `None` where neither does.
pub(super) fn holds(
    build_from_start: &dyn Fn() -> Result<Generator, CalibrateError>,
    healthy: &Healthy<'_>,
    (arrs, integrated): (&[Arr], &[bool]),
    best: &[(Integration, Option<Walk>)],
    (window, onset): (usize, usize),
) -> Result<Vec<Option<HeldBy>>, CalibrateError> {
    let from_start = match arrs.iter().zip(integrated).any(|(a, &i)| i && anchored(a)) {
        true => Some(healthy.residuals(build_from_start()?)),
        false => None,
    };
    Ok((arrs.iter().enumerate())
        .map(|(k, arr)| {
            if !integrated[k] {
                return None;
            }
            let walk = (from_start.as_ref())
                .filter(|_| anchored(arr))
                .and_then(|s| Walk::fit(&s[k], window));
            if walk.is_some() {
                return Some((Integration::Start, true, walk));
            }
            match best[k] {
                (Integration::Window(n), _) if n > onset => {
                    Some((Integration::Window(n), false, None))
                }
                (Integration::Start, walk @ Some(_)) => Some((Integration::Start, false, walk)),
                _ => None,
            }
        })
        .collect())
}
