//! The noise each residual carries, so that residuals are weighed by it: a residual's
//! response to white noise of each raw signal's own level, added to the first samples of a
//! record. Dividing a residual by it makes the fit the whitened (approximately maximum
//! likelihood) one for noise in the signals: a combination of parameters that shrinks a
//! relation towards zero everywhere (the bench's differentiated link law with a very stiff
//! link and its dead zone cancelling it) shrinks its noise as much, and gains nothing; and a
//! parameter that multiplies a noisy signal pays for the noise it lets in, which is what
//! least squares on the plain residual gets wrong (errors in variables).

use crate::sensor::{Draws, Noise};

/// How many samples of a record the noise is probed on: enough for an RMS within a few
/// percent over residuals correlated for a few hundred samples.
pub(super) const PROBE_ROWS: usize = 50_000;

/// A record's first samples, with white noise of each raw signal's level added.
pub(super) struct Probe {
    /// The times of those samples.
    pub(super) time: Vec<f64>,
    /// Each raw signal, noisy.
    pub(super) raw: Vec<Vec<f64>>,
}

impl Probe {
    /// The probe of a record's first `rows` samples (at most all), the noise drawn from
    /// `seed`; `None` where no signal of it has any noise (then there is nothing to weigh
    /// by).
    pub(super) fn of(time: &[f64], raw: &[&[f64]], seed: u64, rows: usize) -> Option<Probe> {
        let rows = time.len().min(rows);
        let levels: Vec<Noise> = (raw.iter())
            .map(|c| level(&c[..c.len().min(PROBE_ROWS)]))
            .collect();
        if levels.iter().all(|l| l.deviation() == 0.0) {
            return None;
        }
        let mut normal = Normal::new(seed);
        let noisy = (raw.iter().zip(&levels))
            .map(|(column, noise)| {
                let e = noise.draw(rows, &mut normal);
                column[..rows].iter().zip(e).map(|(x, e)| x + e).collect()
            })
            .collect();
        Some(Probe {
            time: time[..rows].to_vec(),
            raw: noisy,
        })
    }
}

/// A signal's noise (see [`crate::sensor`]).
pub(super) fn level(column: &[f64]) -> Noise {
    Noise::read(column)
}

/// Standard normal numbers (Box–Muller over a xorshift): the same on every run.
#[derive(Clone)]
pub(super) struct Normal {
    state: u64,
    spare: Option<f64>,
}

impl Normal {
    pub(super) fn new(seed: u64) -> Normal {
        Normal {
            state: seed | 1,
            spare: None,
        }
    }

    fn uniform(&mut self) -> f64 {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        ((self.state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    pub(super) fn next(&mut self) -> f64 {
        if let Some(x) = self.spare.take() {
            return x;
        }
        let (a, b) = (self.uniform(), self.uniform());
        let radius = (-2.0 * a.ln()).sqrt();
        let angle = std::f64::consts::TAU * b;
        self.spare = Some(radius * angle.sin());
        radius * angle.cos()
    }
}

/// Sequential: the sample's index is not read.
impl Draws for Normal {
    fn gaussian(&mut self, _: u64) -> f64 {
        self.next()
    }

    fn uniform(&mut self, _: u64) -> f64 {
        Normal::uniform(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_of_white_noise_on_a_smooth_signal_and_none_on_a_square_wave() {
        let mut normal = Normal::new(7);
        let noisy: Vec<f64> = (0..20_000)
            .map(|k| (k as f64 * 1e-3).sin() + 0.01 * normal.next())
            .collect();
        let found = level(&noisy).deviation();
        assert!((found / 0.01 - 1.0).abs() < 0.05, "{found}");
        let square: Vec<f64> = (0..20_000)
            .map(|k| if (k / 500) % 2 == 0 { 5.0 } else { 15.0 })
            .collect();
        assert_eq!(level(&square).deviation(), 0.0);
    }
}
