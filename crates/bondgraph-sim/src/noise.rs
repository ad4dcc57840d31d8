//! Seeded Gaussian noise that does not depend on the order it is drawn in.
//!
//! Each sample's noise is a hash of (seed, signal, sample index), so a run gives the same noise
//! on every machine and whichever pieces the integration was cut into.

/// SplitMix64's finaliser: a bijection of 64-bit words that mixes every bit into every other.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in (0, 1] from a hash.
fn unit(z: u64) -> f64 {
    ((z >> 11) as f64 + 1.0) / (1u64 << 53) as f64
}

/// A standard normal number for `signal`'s `sample`-th value under `seed` (Box–Muller).
pub fn gaussian(seed: u64, signal: u64, sample: u64) -> f64 {
    let key = mix(mix(seed ^ mix(signal)) ^ sample);
    let (u1, u2) = (unit(mix(key)), unit(mix(key ^ 0xD6E8_FEB8_6659_FD93)));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A number uniform in (0, 1] for `signal`'s `sample`-th value under `seed`, drawn apart
/// from [`gaussian`]'s.
pub fn uniform(seed: u64, signal: u64, sample: u64) -> f64 {
    let key = mix(mix(seed ^ mix(signal)) ^ sample);
    unit(mix(key ^ 0x2545_F491_4F6C_DD1D))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean 0 and variance 1 within what 200,000 draws allow; another seed, other numbers.
    #[test]
    fn the_noise_is_standard_normal_and_seeded() {
        let n = 200_000u64;
        let draws: Vec<f64> = (0..n).map(|k| gaussian(42, 3, k)).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.02, "{var}");
        let beyond = draws.iter().filter(|x| x.abs() > 3.0).count() as f64 / n as f64;
        assert!((beyond - 0.0027).abs() < 0.0008, "{beyond}");
        assert_ne!(gaussian(42, 3, 0), gaussian(43, 3, 0));
        assert_eq!(gaussian(42, 3, 7), gaussian(42, 3, 7));
    }
}
