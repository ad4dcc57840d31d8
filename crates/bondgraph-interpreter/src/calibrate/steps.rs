//! The steps of a recorded signal (a heater switched, a square wave's edges), whose instant
//! within their sample interval no record tells.
//!
//! A signal that steps by Δ somewhere between two samples is recorded the same whatever the
//! instant; the plant, though, responded to the instant. So every estimate that integrates or
//! smooths the samples across the step is off by up to Δ·h/2 (h the step between samples),
//! one way or the other, and the next record's steps fall at other instants than the healthy
//! record's. To first order that error is an impulse of area Δ·h·(θ − ½), θ the instant's
//! place in its interval, uniform where nothing ties the steps to the sampling clock: a change
//! of Δ·(θ − ½) in the sample that first holds the new level, which is what the replicas add
//! at each step (a heater sampled every 0.5 s switched at random instants false-alarmed on 1
//! healthy record of 4 with thresholds that priced the noise alone).

/// How far above the signal's ordinary curvature (its median, in robust deviations) and above
/// its noise a step stands out.
const STANDS_OUT: f64 = 8.0;

/// The least step, as a share of the signal's range: a quantised signal's one-count steps
/// (an encoder read in counts) are its quantisation, not steps of its drive.
const LEAST_SHARE: f64 = 0.01;

/// Each step of `x` (white noise of deviation `sigma` on it): the sample that first holds
/// the new level, and the jump (net of the signal's slope there).
pub(crate) fn steps(x: &[f64], sigma: f64) -> Vec<(usize, f64)> {
    // The jump at k net of the slope on either side: x_k − x_{k−1} less the mean of the
    // differences before and after it (noise deviation σ √2.5).
    let jump = |k: usize| {
        let d = |j: usize| x[j] - x[j - 1];
        d(k) - 0.5 * (d(k - 1) + d(k + 1))
    };
    if x.len() < 4 {
        return Vec::new();
    }
    let jumps: Vec<f64> = (2..x.len() - 1).map(jump).collect();
    let mut magnitudes: Vec<f64> = (jumps.iter())
        .filter(|v| v.is_finite())
        .map(|v| v.abs())
        .collect();
    if magnitudes.is_empty() {
        return Vec::new();
    }
    let mid = magnitudes.len() / 2;
    let median = *magnitudes.select_nth_unstable_by(mid, f64::total_cmp).1;
    let (lo, hi) = (x.iter().filter(|v| v.is_finite()))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let level = (STANDS_OUT * median / 0.6745)
        .max(STANDS_OUT * sigma * 2.5f64.sqrt())
        .max(LEAST_SHARE * (hi - lo));
    if !(level > 0.0 && level.is_finite()) {
        return Vec::new();
    }
    // A step shows as one large jump with half of it, the other way, on either side: the
    // largest of the three is the step.
    let at = |j: usize| jumps.get(j).map_or(0.0, |v: &f64| v.abs());
    (0..jumps.len())
        .filter(|&j| at(j) > level && at(j) >= at(j.wrapping_sub(1)) && at(j) > at(j + 1))
        .map(|j| (j + 2, jumps[j]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square wave on a slope, with noise: each edge found at the sample that first holds
    /// the new level, with its jump; the slope and the noise found as none.
    #[test]
    fn the_steps_of_a_square_wave_are_found_and_nothing_else() {
        let x: Vec<f64> = (0..10_000)
            .map(|k| {
                let level = if (k / 1_000) % 2 == 0 { 0.0 } else { 10.0 };
                level + 1e-3 * k as f64 + 0.01 * bondgraph_sim::gaussian(1, 0, k as u64)
            })
            .collect();
        let found = steps(&x, 0.01);
        let at: Vec<usize> = found.iter().map(|s| s.0).collect();
        assert_eq!(at, (1..10).map(|k| k * 1_000).collect::<Vec<_>>());
        for (k, (_, jump)) in found.iter().enumerate() {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            assert!((jump - sign * 10.0).abs() < 0.1, "{jump}");
        }
        let smooth: Vec<f64> = (0..10_000).map(|k| (k as f64 * 1e-3).sin()).collect();
        assert!(steps(&smooth, 0.0).is_empty());
    }

    /// An angle read in counts of 1e-3 over a range of 6: its one-count steps are its
    /// quantisation, not steps.
    #[test]
    fn a_quantised_signal_has_no_steps() {
        let x: Vec<f64> = (0..10_000)
            .map(|k| ((6.0 * (k as f64 * 3e-4).sin()) / 1e-3).round() * 1e-3)
            .collect();
        assert!(steps(&x, 0.0).is_empty());
    }
}
