//! Where a record has settled: a record that starts at rest (every real one) starts with a
//! transient the estimators cannot follow — a motor's speed from 0 to its working point in a
//! few windows — and their estimates of the derivatives are wrong there by more than any
//! noise, whatever the plant does. The test is the polynomial fits' own: over a window, the
//! scatter of a signal about its least-squares polynomial is its noise where the polynomial
//! follows it (a chi-square with `window − degree − 1` degrees of freedom), and far more where
//! it does not. A record has settled at the first window from which every differentiated
//! signal is followed, window after window, for a whole window; the samples before are left
//! out as `--from` would leave them, and the user is told.

/// How far above its noise's variance a signal's mean square scatter about its polynomial may
/// be, in standard deviations of the chi-square the noise alone gives it.
const SCATTER: f64 = 4.0;

/// The share of a record within which it must settle: a record that never does is one whose
/// signals the estimator never follows, not a start-up, and is left whole.
const WITHIN: usize = 4;

/// Half a window into the first window from which each column of `columns` marked in
/// `differentiated` (and with noise, `deviations` above 0) is followed by a polynomial of
/// `degree` over `window` samples for a whole window of windows; `None` where that window is
/// the record's first, or where the record does not settle within a quarter of its length.
pub(super) fn settled(
    columns: &[&[f64]],
    deviations: &[f64],
    differentiated: &[bool],
    (window, degree): (usize, u32),
) -> Option<usize> {
    let basis = orthonormal(window, degree as usize);
    let freedom = window.saturating_sub(degree as usize + 1).max(1) as f64;
    let limit = 1.0 + SCATTER * (2.0 / freedom).sqrt();
    let mut from = 0;
    for ((column, &sigma), _) in (columns.iter().zip(deviations).zip(differentiated))
        .filter(|((_, &sigma), &d)| d && sigma > 0.0)
    {
        let last = column.len() / WITHIN;
        let followed = |start: usize| {
            scatter(&column[start..start + window], &basis) <= limit * freedom * sigma * sigma
        };
        let mut start = from;
        let mut run = 0;
        while run < window {
            if start + run + window > column.len() || start > last {
                return None;
            }
            if followed(start + run) {
                run += 1;
            } else {
                start += run + 1;
                run = 0;
            }
        }
        // The first window followed is at the edge of what was not: its own polynomial is
        // nearly right, not its derivatives. Half a window on, every estimate's window lies
        // within windows that are followed.
        if start > 0 {
            from = from.max(start + window / 2);
        }
    }
    (from > 0).then_some(from)
}

/// The sum of squares of `y` about its least-squares polynomial on the orthonormal `basis`.
fn scatter(y: &[f64], basis: &[Vec<f64>]) -> f64 {
    let total: f64 = y.iter().map(|v| v * v).sum();
    let explained: f64 = (basis.iter())
        .map(|q| q.iter().zip(y).map(|(a, b)| a * b).sum::<f64>().powi(2))
        .sum();
    (total - explained).max(0.0)
}

/// Polynomials of degree 0 to `degree` over `window` evenly spaced points, orthonormal
/// (Gram–Schmidt on the centred powers, twice for rounding).
fn orthonormal(window: usize, degree: usize) -> Vec<Vec<f64>> {
    let half = (window as f64 - 1.0) / 2.0;
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for power in 0..=degree.min(window.saturating_sub(1)) {
        let mut v: Vec<f64> = (0..window)
            .map(|k| ((k as f64 - half) / half.max(1.0)).powi(power as i32))
            .collect();
        for _ in 0..2 {
            for q in &basis {
                let dot: f64 = q.iter().zip(&v).map(|(a, b)| a * b).sum();
                for (x, a) in v.iter_mut().zip(q) {
                    *x -= dot * a;
                }
            }
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 0.0 {
            basis.push(v.iter().map(|x| x / norm).collect());
        }
    }
    basis
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A speed that rises from rest in 0.1 s and then follows a slow sine, with noise: it
    /// settles once the rise is a window behind, and a slow signal from the start is settled
    /// at once.
    #[test]
    fn a_record_from_rest_settles_after_its_start_up() {
        let n = 20_000;
        let noise = |k: usize| 0.05 * bondgraph_sim::gaussian(9, 0, k as u64);
        let rising: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                270.0 * (1.0 - (-t / 0.02).exp()) + 5.0 * (0.3 * t).sin() + noise(k)
            })
            .collect();
        let at = settled(&[&rising], &[0.05], &[true], (51, 3)).expect("a start-up");
        // The exponential's curvature is within the noise some ten time constants on.
        assert!(at > 75 && at < 450, "{at}");
        let slow: Vec<f64> = (0..n)
            .map(|k| 5.0 * (0.3 * k as f64 * 1e-3).sin() + noise(k))
            .collect();
        assert_eq!(settled(&[&slow], &[0.05], &[true], (51, 3)), None);
        // A column not differentiated, or without noise, is not tested.
        assert_eq!(settled(&[&rising], &[0.05], &[false], (51, 3)), None);
        assert_eq!(settled(&[&rising], &[0.0], &[true], (51, 3)), None);
    }

    #[test]
    fn the_scatter_about_a_cubic_is_zero_for_a_cubic() {
        let basis = orthonormal(21, 3);
        let cubic: Vec<f64> = (0..21)
            .map(|k| (k as f64).powi(3) - 4.0 * k as f64)
            .collect();
        assert!(scatter(&cubic, &basis) < 1e-6 * cubic.iter().map(|v| v * v).sum::<f64>());
        let quartic: Vec<f64> = (0..21).map(|k| (k as f64).powi(4)).collect();
        assert!(scatter(&quartic, &basis) > 1.0);
    }
}
