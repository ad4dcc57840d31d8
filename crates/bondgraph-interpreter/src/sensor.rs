//! How a recorded signal's noise is made, read from the signal: white noise of a deviation,
//! or a quantiser's. What the fit weighs residuals by and what calibration draws again.
//!
//! A signal on a lattice (every sample a whole number of one quantum apart, changing level
//! often) is a quantiser's output: an encoder's angle in counts, or a speed taken as the
//! difference of two counts over a sample. A robust white-noise reading (medians of
//! differences, see [`crate::deviation`]) reads such a signal as almost noiseless, because
//! most of its differences are exactly zero; yet its error is a whole count about half the
//! time. Its error is modelled as a quantiser's (Widrow's model): the true value's place
//! between two counts, uniform within one quantum and independent from sample to sample —
//! `q (U − ½)` on an angle read directly, `q (U_k − U_{k−1})` on a speed from differences of
//! counts, whose errors are the two counts' and so are correlated (−½ from one sample to the
//! next) and do not accumulate. Which of the two a lattice is, the second differences tell:
//! in quanta², their mean square is 20/12 for a difference of counts and 6/12 (or less,
//! where the angle moves slowly and the counts stair) for an angle read directly.

/// Fewest samples for a lattice to be read.
const LEAST_SAMPLES: usize = 64;

/// Most levels a lattice spans (a 24-bit converter's, an encoder's turns of counts): a finer
/// one is quantised below anything its noise shows.
const MOST_LEVELS: f64 = (1u64 << 24) as f64;

/// How far from a whole number of quanta (in quanta) a sample on a lattice may be: what
/// printing the record in decimal leaves.
const ON_LATTICE: f64 = 1e-3;

/// The least share of samples that change level: below it, a signal on a lattice is a
/// commanded input switched between a few levels, not a quantiser's output.
const CHANGING: f64 = 0.01;

/// The mean square of the second differences (in quanta²) above which a lattice is a
/// difference of counts: between 6/12 (an angle read directly) and 20/12.
const DIFFERENCED: f64 = 0.9;

/// How a lattice's values were read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Reading {
    /// The quantity itself, quantised (an encoder's angle in counts).
    Direct,
    /// The difference of two quantised readings over a sample (a speed from counts).
    Differenced,
}

/// A recorded signal's noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Noise {
    /// White noise of this deviation (0 where there is none: an input as commanded).
    White(f64),
    /// A quantiser's error, on a lattice of this quantum.
    Quantised {
        /// The lattice's spacing, in the signal's unit.
        quantum: f64,
        /// Whether the signal is a quantised reading or a difference of two.
        reading: Reading,
    },
}

/// Where a noise draw's numbers come from: counter-based (by sample) or sequential.
pub(crate) trait Draws {
    /// A standard normal number for sample `k`.
    fn gaussian(&mut self, k: u64) -> f64;
    /// A number uniform in (0, 1) for sample `k`, apart from [`Draws::gaussian`]'s.
    fn uniform(&mut self, k: u64) -> f64;
}

impl Noise {
    /// The noise of column `x`, read from it.
    pub(crate) fn read(x: &[f64]) -> Noise {
        let white = crate::deviation::deviation(x);
        match lattice(x) {
            Some(quantum) if white < quantum / 12f64.sqrt() => Noise::Quantised {
                quantum,
                reading: reading(x, quantum),
            },
            _ => Noise::White(white),
        }
    }

    /// The deviation of one sample's error.
    pub(crate) fn deviation(&self) -> f64 {
        match *self {
            Noise::White(sigma) => sigma,
            Noise::Quantised { quantum, reading } => match reading {
                Reading::Direct => quantum / 12f64.sqrt(),
                Reading::Differenced => quantum / 6f64.sqrt(),
            },
        }
    }

    /// `n` samples of fresh noise of this kind.
    pub(crate) fn draw(&self, n: usize, draws: &mut impl Draws) -> Vec<f64> {
        match *self {
            Noise::White(sigma) => (0..n).map(|k| sigma * draws.gaussian(k as u64)).collect(),
            Noise::Quantised { quantum, reading } => {
                let place: Vec<f64> = (0..=n).map(|k| draws.uniform(k as u64)).collect();
                match reading {
                    Reading::Direct => (place[..n].iter()).map(|u| quantum * (u - 0.5)).collect(),
                    Reading::Differenced => (place.windows(2))
                        .map(|w| quantum * (w[1] - w[0]))
                        .collect(),
                }
            }
        }
    }

    /// How the note says it: `1.2e-4` for white noise, `quantised by 1.53e0 (differences of
    /// counts)` for a lattice.
    pub(crate) fn said(&self) -> String {
        match *self {
            Noise::White(sigma) => format!("{sigma:.2e}"),
            Noise::Quantised { quantum, reading } => format!(
                "quantised by {quantum:.3e} ({})",
                match reading {
                    Reading::Direct => "read directly",
                    Reading::Differenced => "differences of counts",
                }
            ),
        }
    }
}

/// The quantum of `x`'s lattice, where it is on one (see the module's doc).
fn lattice(x: &[f64]) -> Option<f64> {
    if x.len() < LEAST_SAMPLES || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let (lo, hi) = (x.iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
        (l.min(v), h.max(v))
    });
    // The lattice's spacing divides every difference between samples: their greatest
    // common divisor, to within what printing leaves of the smallest.
    let tiny = (hi - lo) / MOST_LEVELS;
    let smallest = (x.windows(2))
        .map(|w| (w[1] - w[0]).abs())
        .filter(|&d| d > tiny)
        .fold(f64::INFINITY, f64::min);
    if !smallest.is_finite() {
        return None;
    }
    let tolerance = ON_LATTICE * smallest;
    let quantum = (x.windows(2))
        .map(|w| (w[1] - w[0]).abs())
        .filter(|&d| d > tiny)
        .fold(smallest, |g, d| {
            if g > tolerance {
                divisor(g, d, tolerance)
            } else {
                g
            }
        });
    if quantum <= tiny.max(tolerance) || (hi - lo) / quantum < 2.0 {
        return None;
    }
    let on = x.iter().all(|v| {
        let k = (v - lo) / quantum;
        (k - k.round()).abs() <= ON_LATTICE
    });
    let changes = x.windows(2).filter(|w| w[1] != w[0]).count();
    (on && changes as f64 >= CHANGING * x.len() as f64).then_some(quantum)
}

/// The greatest common divisor of `a` and `b`, remainders within `tolerance` of 0 or of the
/// divisor taken as none (Euclid's algorithm on reals).
fn divisor(mut a: f64, mut b: f64, tolerance: f64) -> f64 {
    loop {
        if b <= tolerance {
            return a;
        }
        let r = a.rem_euclid(b);
        let r = if b - r <= tolerance { 0.0 } else { r };
        (a, b) = (b, r);
    }
}

/// Whether a lattice of `quantum` is read directly or as differences (see the module's doc).
fn reading(x: &[f64], quantum: f64) -> Reading {
    let second: Vec<f64> = (x.windows(3))
        .map(|w| ((w[2] - 2.0 * w[1] + w[0]) / quantum).round())
        .collect();
    let square = second.iter().map(|d| d * d).sum::<f64>() / second.len().max(1) as f64;
    if square > DIFFERENCED {
        Reading::Differenced
    } else {
        Reading::Direct
    }
}

/// Counter-based draws for one stream of `seed` (see `bondgraph_sim::gaussian`).
pub(crate) struct Counter {
    /// The seed of every stream.
    pub(crate) seed: u64,
    /// This stream.
    pub(crate) stream: u64,
}

/// Set in a stream's number for its quantisation's places, so that they are apart from the
/// uniform numbers the same stream draws for other things (the instants of input steps).
const PLACES: u64 = 1 << 31;

impl Draws for Counter {
    fn gaussian(&mut self, k: u64) -> f64 {
        bondgraph_sim::gaussian(self.seed, self.stream, k)
    }

    fn uniform(&mut self, k: u64) -> f64 {
        bondgraph_sim::uniform(self.seed, self.stream ^ PLACES, k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An encoder of 4,096 counts per revolution read at 1 kHz on a shaft turning at
    /// 10-20 rad/s, from a random first count.
    fn encoder(n: usize) -> (Vec<f64>, Vec<f64>, f64) {
        let step = 1e-3;
        let quantum = std::f64::consts::TAU / 4096.0;
        let mut angle = 0.0;
        let mut counts = Vec::with_capacity(n);
        for k in 0..n {
            let t = k as f64 * step;
            angle += (15.0 + 5.0 * (0.7 * t).sin()) * step;
            counts.push((angle / quantum + 0.37).floor() * quantum);
        }
        let speed: Vec<f64> = std::iter::once(0.0)
            .chain(counts.windows(2).map(|w| (w[1] - w[0]) / step))
            .collect();
        (counts, speed, quantum)
    }

    #[test]
    fn an_encoders_angle_and_a_speed_from_its_counts_are_read_as_quantised() {
        let (angle, speed, quantum) = encoder(50_000);
        match Noise::read(&angle) {
            Noise::Quantised {
                quantum: q,
                reading,
            } => {
                assert!((q / quantum - 1.0).abs() < 1e-9, "{q}");
                assert_eq!(reading, Reading::Direct);
            }
            other => panic!("{other:?}"),
        }
        match Noise::read(&speed) {
            Noise::Quantised {
                quantum: q,
                reading,
            } => {
                assert!((q * 1e-3 / quantum - 1.0).abs() < 1e-9, "{q}");
                assert_eq!(reading, Reading::Differenced);
            }
            other => panic!("{other:?}"),
        }
    }

    /// What the module's doc says a differenced quantiser's error is: deviation q/√6,
    /// correlated −½ from one sample to the next; a direct one's q/√12 and uncorrelated.
    #[test]
    fn the_draws_have_the_quantisers_deviation_and_correlation() {
        for (reading, deviation, lag) in [
            (Reading::Differenced, 1.0 / 6f64.sqrt(), -0.5),
            (Reading::Direct, 1.0 / 12f64.sqrt(), 0.0),
        ] {
            let noise = Noise::Quantised {
                quantum: 1.0,
                reading,
            };
            let e = noise.draw(200_000, &mut Counter { seed: 5, stream: 0 });
            let n = e.len() as f64;
            let var = e.iter().map(|v| v * v).sum::<f64>() / n;
            let cov = e.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / n;
            assert!(
                (var.sqrt() / deviation - 1.0).abs() < 0.01,
                "{reading:?} {var}"
            );
            assert!((cov / var - lag).abs() < 0.01, "{reading:?} {}", cov / var);
            assert!(e.iter().all(|v| v.abs() <= 1.0));
        }
    }

    /// A square input between two levels, a noisy signal, a smooth one: none is a lattice.
    #[test]
    fn inputs_noise_and_smooth_signals_are_not_lattices() {
        let square: Vec<f64> = (0..20_000)
            .map(|k| if (k / 500) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        assert_eq!(Noise::read(&square), Noise::White(0.0));
        let steps: Vec<f64> = (0..20_000).map(|k| (k / 500) as f64).collect();
        assert_eq!(Noise::read(&steps), Noise::White(0.0));
        let smooth: Vec<f64> = (0..20_000).map(|k| (k as f64 * 1e-3).sin()).collect();
        assert!(matches!(Noise::read(&smooth), Noise::White(s) if s < 1e-9));
        let noisy: Vec<f64> = (0..20_000)
            .map(|k| bondgraph_sim::gaussian(1, 0, k as u64))
            .collect();
        assert!(matches!(Noise::read(&noisy), Noise::White(s) if (s - 1.0).abs() < 0.05));
    }
}
