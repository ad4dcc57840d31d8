//! A recorded signal's white-noise deviation, read from the signal itself: what the fit
//! weighs residuals by and what calibration draws fresh noise of.
//!
//! White noise of deviation σ gives the k-th differences a deviation σ √C(2k, k) (6 for the
//! second, 20 for the third), and a signal smooth at the sampling rate next to nothing; the
//! median of their magnitudes (over 0.6745 deviations) leaves out jumps and spikes. A
//! wideband signal is not smooth at the sampling rate, and its differences carry it: a
//! multisine driven up to a fifth of the sampling rate read as twenty times its noise. So
//! the differences are also read stretch by stretch, and where the quietest stretches (where
//! the signal rests, or moves slowly) show far less than the whole, the noise is theirs.

/// The differences' orders read: the second (least noise gain) and the third (which follows
/// a faster signal's curvature without it).
const ORDERS: [(usize, f64); 2] = [(2, 6.0), (3, 20.0)];

/// Differences in each stretch.
const STRETCH: usize = 256;

/// Fewest stretches for the stretch-by-stretch reading.
const LEAST_STRETCHES: usize = 8;

/// The share of stretches, the quietest first, whose median is read.
const QUIET: f64 = 0.1;

/// How much quieter than the whole the quietest stretches must read for their level to be
/// taken: white noise's own stretches scatter by a few percent, a signal in the whole by
/// more than this.
const QUIETER: f64 = 0.7;

/// The column's white-noise deviation (0 where it has none: an input as commanded).
pub(crate) fn deviation(x: &[f64]) -> f64 {
    let found = (ORDERS.iter())
        .map(|&(order, gain)| {
            let d = differences(x, order);
            let whole = median_abs(&mut d.clone()) / 0.6745 / gain.sqrt();
            match quiet(&d) {
                Some(q) if q < QUIETER * whole => {
                    // What the same reading gives on white noise of deviation 1 whose
                    // differences are correlated as these are: the quietest stretches of
                    // pure noise read low, by a factor this measures.
                    let unit = differences(&white(x.len()), order);
                    let bias = quiet(&unit).unwrap_or(1.0) / median_abs(&mut unit.clone());
                    q / 0.6745 / gain.sqrt() / bias.max(f64::MIN_POSITIVE)
                }
                _ => whole,
            }
        })
        .fold(f64::INFINITY, f64::min);
    if found.is_finite() {
        found.max(0.0)
    } else {
        0.0
    }
}

/// The `order`-th differences of `x` (finite ones only).
fn differences(x: &[f64], order: usize) -> Vec<f64> {
    let mut d: Vec<f64> = x.to_vec();
    for _ in 0..order {
        d = d.windows(2).map(|w| w[1] - w[0]).collect();
    }
    d.retain(|v| v.is_finite());
    d
}

/// The median of the magnitudes (0 for none).
pub(crate) fn median_abs(d: &mut [f64]) -> f64 {
    if d.is_empty() {
        return 0.0;
    }
    for v in d.iter_mut() {
        *v = v.abs();
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The median of the stretches' medians of magnitudes, over the quietest [`QUIET`] of them;
/// `None` for too few stretches.
fn quiet(d: &[f64]) -> Option<f64> {
    let stretches = d.len() / STRETCH;
    if stretches < LEAST_STRETCHES {
        return None;
    }
    let mut medians: Vec<f64> = (d.chunks_exact(STRETCH))
        .map(|c| median_abs(&mut c.to_vec()))
        .collect();
    medians.sort_by(f64::total_cmp);
    let kept = ((stretches as f64 * QUIET).ceil() as usize).max(1);
    Some(median_abs(&mut medians[..kept].to_vec()))
}

/// `n` samples of white noise of deviation 1 (the same on every run).
fn white(n: usize) -> Vec<f64> {
    let mut state = 0x853C_49E6_748F_EA9Bu64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let (a, b) = (uniform(), uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_on_a_smooth_signal_reads_as_its_deviation_and_none_as_zero() {
        let noise = white(40_000);
        let x: Vec<f64> = (0..40_000)
            .map(|k| (k as f64 * 1e-3).sin() + 0.01 * noise[(k * 7919) % 40_000])
            .collect();
        let found = deviation(&x);
        assert!((found / 0.01 - 1.0).abs() < 0.05, "{found}");
        let clean: Vec<f64> = (0..1000).map(|k| 3.0 + k as f64 * 0.5).collect();
        assert!(deviation(&clean) < 1e-9);
        let square: Vec<f64> = (0..20_000)
            .map(|k| if (k / 500) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        assert_eq!(deviation(&square), 0.0);
    }

    /// A multisine up to a fifth of the sampling rate, with rests between its bursts: the
    /// whole record's differences read the signal, its rests the noise.
    #[test]
    fn a_wideband_signal_with_rests_reads_the_noise_of_its_rests() {
        let noise = white(60_000);
        let x: Vec<f64> = (0..60_000)
            .map(|k| {
                let t = k as f64;
                let burst = (k / 3000) % 2 == 0;
                let signal = if burst {
                    (1..=20)
                        .map(|j| (0.06 * j as f64 * t + j as f64).sin())
                        .sum::<f64>()
                } else {
                    0.0
                };
                signal + 5e-4 * noise[(k * 7919) % 60_000]
            })
            .collect();
        let found = deviation(&x);
        assert!((found / 5e-4 - 1.0).abs() < 0.15, "{found}");
    }
}
