//! Where a record's signals jump (a square wave's edge, a step of a set point): there the
//! estimators' assumptions fail. A polynomial fit straddling the jump is wrong over its
//! window, and the trapezoidal integral of a sampled step differs from the plant's by half a
//! step times the jump, an error an integrated residual carries for its whole window. Both
//! are deterministic and would bias a fit on a record with many edges, so the estimates
//! within their reach are left out of it.

/// How much larger than a signal's typical change between samples a change must be to be a
/// jump.
const JUMP: f64 = 20.0;

/// The samples (by index) at which some signal of `raw` jumps from the sample before.
pub(super) fn jumps(raw: &[&[f64]]) -> Vec<usize> {
    let mut at: Vec<usize> = Vec::new();
    for column in raw {
        let mut changes: Vec<f64> = column.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        if changes.is_empty() {
            continue;
        }
        let middle = changes.len() / 2;
        let typical = *changes
            .clone()
            .select_nth_unstable_by(middle, f64::total_cmp)
            .1;
        for (k, d) in changes.drain(..).enumerate() {
            if d > 0.0 && d > JUMP * typical {
                at.push(k + 1);
            }
        }
    }
    at.sort_unstable();
    at.dedup();
    at
}

/// How many samples per jump, at fewest, a record of a step input's edges holds: a signal
/// that jumps more often (a closed loop's drive fed back from a quantised encoder jumps on
/// one sample in twenty on the EMPS axis) changes fast throughout.
const SAMPLES_PER_EDGE: usize = 50;

/// For each estimate of a record of `samples` samples, whether it is left out of the fit for
/// a jump of a signal of `raw` within its reach; none is when the signals jump on more than
/// one sample in [`SAMPLES_PER_EDGE`], or the jumps would leave out more than half the
/// record: such a signal (a closed loop's drive) changes fast throughout, and its fast
/// changes are what the record holds, not a step input's edges. (Judged by the windows
/// alone, the EMPS axis's drive was the signal at an integration window of 250 samples and
/// edges at 125, which left out the stretches that determine its mass: 45 times too large.)
pub(super) fn left_out(
    raw: &[&[f64]],
    samples: usize,
    window: usize,
    integration: usize,
) -> Vec<bool> {
    let at = jumps(raw);
    let out = reached(&at, samples, window, integration);
    let count = out.iter().filter(|&&x| x).count();
    if 2 * count > samples || at.len() * SAMPLES_PER_EDGE > samples {
        vec![false; samples]
    } else {
        out
    }
}

/// For each estimate of a record of `samples` samples, whether a jump at `jumps` is within
/// its reach: the estimate at place `p` reads samples `p .. p + window` and, integrated,
/// the estimates `integration` before it.
pub(super) fn reached(
    jumps: &[usize],
    samples: usize,
    window: usize,
    integration: usize,
) -> Vec<bool> {
    let mut reached = vec![false; samples];
    for &j in jumps {
        // A jump between samples j - 1 and j reaches the places whose span holds both.
        let first = j.saturating_sub(window);
        let last = (j + integration).min(samples.saturating_sub(1));
        for r in reached.iter_mut().take(last + 1).skip(first) {
            *r = true;
        }
    }
    reached
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_waves_edges_are_jumps_and_a_noisy_sine_has_none() {
        let square: Vec<f64> = (0..1000)
            .map(|k| if (k / 100) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        assert_eq!(
            jumps(&[&square]),
            (1..10).map(|k| 100 * k).collect::<Vec<_>>()
        );
        let sine: Vec<f64> = (0..1000)
            .map(|k| (k as f64 * 0.01).sin() + 1e-3 * ((k * 7919 % 13) as f64 - 6.0))
            .collect();
        assert!(jumps(&[&sine]).is_empty());
    }

    #[test]
    fn jumps_throughout_a_record_leave_nothing_out() {
        let square: Vec<f64> = (0..1000)
            .map(|k| if (k / 100) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        let edges = left_out(&[&square], 1000, 11, 20);
        assert_eq!(edges.iter().filter(|&&x| x).count(), 9 * 32);
        let chatter: Vec<f64> = (0..1000)
            .map(|k| if k % 7 == 0 { 40.0 } else { (k % 3) as f64 })
            .collect();
        assert!(left_out(&[&chatter], 1000, 11, 20).iter().all(|&x| !x));
        // Edges every 30 samples leave out under half the record through short windows,
        // and are still the signal itself.
        let fast: Vec<f64> = (0..3000)
            .map(|k| if (k / 30) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        assert!(left_out(&[&fast], 3000, 3, 3).iter().all(|&x| !x));
    }

    #[test]
    fn a_jump_reaches_the_estimates_whose_windows_hold_it() {
        let reached = reached(&[50], 100, 11, 20);
        let places: Vec<usize> = (0..100).filter(|&p| reached[p]).collect();
        assert_eq!(places.first(), Some(&39));
        assert_eq!(places.last(), Some(&70));
        assert_eq!(places.len(), 32);
    }
}
