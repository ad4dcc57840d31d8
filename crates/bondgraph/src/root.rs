//! The root of a law that has no closed-form inverse, found again at every sample.
//!
//! An ARR that reads a law the other way (a hardening spring's stretch from its force,
//! `k1 q + k3 q³ = e`) holds the variable as the root of `g(z) = 0`. Between two samples the
//! root moves little, so Newton's method from the last one takes two or three steps; where it
//! does not converge (a slope near zero, a step that leaves the law's domain), the root is
//! bracketed around the last one and bisected. Where neither finds it, the sample has no
//! root: [`RootFinder::solve`] says so (`None`), the residuals that read it are not a number
//! there, and the generator names the root (never a silent NaN).

/// Newton steps tried before bracketing.
const NEWTON_STEPS: usize = 50;

/// Doublings of the search interval around the last root: from `1e-3 max(1, |z|)` up to
/// about `1e15 max(1, |z|)`.
const BRACKET_DOUBLINGS: usize = 60;

/// Bisections: enough to reach the last bit of an `f64` from any bracket.
const BISECTIONS: usize = 200;

/// Finds a root of a law at each sample, from the root of the sample before.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RootFinder {
    last: Option<f64>,
    failures: u64,
}

impl RootFinder {
    /// What a generator gives a root that has no solution at a sample (not a number), with
    /// the root named by the generator's `unsolved()`: the residuals that read it say nothing
    /// there, and no threshold takes them for zero.
    pub const NO_ROOT: f64 = f64::NAN;

    /// A finder that starts from zero.
    #[must_use]
    pub fn new() -> RootFinder {
        RootFinder::default()
    }

    /// A root of `g`, given as `z ↦ (g(z), g'(z))`, from the last root found; `None` where
    /// none is found (the next sample starts from the last root found).
    pub fn solve(&mut self, mut g: impl FnMut(f64) -> (f64, f64)) -> Option<f64> {
        let start = self.last.unwrap_or(0.0);
        let root = newton(&mut g, start).or_else(|| bracket(&mut g, start));
        match root {
            Some(z) => self.last = Some(z),
            None => self.failures += 1,
        }
        root
    }

    /// The last root found, if any.
    #[must_use]
    pub fn last(&self) -> Option<f64> {
        self.last
    }

    /// How many samples had no root.
    #[must_use]
    pub fn failures(&self) -> u64 {
        self.failures
    }
}

/// Newton's method from `z`; `None` when it does not converge.
fn newton(g: &mut impl FnMut(f64) -> (f64, f64), mut z: f64) -> Option<f64> {
    for _ in 0..NEWTON_STEPS {
        let (value, slope) = g(z);
        if value == 0.0 {
            return Some(z);
        }
        // An infinite slope (a law like sqrt at the edge of its domain) would stop Newton
        // where it stands, as if converged.
        let step = value / slope;
        if !step.is_finite() || !slope.is_finite() {
            return None;
        }
        z -= step;
        if step.abs() <= 4.0 * f64::EPSILON * z.abs().max(f64::MIN_POSITIVE) {
            return g(z).0.is_finite().then_some(z);
        }
    }
    None
}

/// A sign change of `g` around `z`, bisected; `None` when none is found.
fn bracket(g: &mut impl FnMut(f64) -> (f64, f64), z: f64) -> Option<f64> {
    let at = |g: &mut dyn FnMut(f64) -> (f64, f64), x: f64| g(x).0;
    let g0 = at(g, z);
    if g0 == 0.0 {
        return Some(z);
    }
    let mut width = 1e-3 * z.abs().max(1.0);
    for _ in 0..BRACKET_DOUBLINGS {
        for other in [z + width, z - width] {
            let value = at(g, other);
            if g0.is_finite() && value.is_finite() && (value == 0.0 || (value > 0.0) != (g0 > 0.0))
            {
                return Some(bisect(g, z, g0, other));
            }
        }
        width *= 2.0;
    }
    None
}

/// Bisects `[a, b]`, where `g` changes sign and `g(a) = ga`.
fn bisect(g: &mut impl FnMut(f64) -> (f64, f64), mut a: f64, mut ga: f64, mut b: f64) -> f64 {
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (a + b);
        if mid == a || mid == b {
            break;
        }
        let gm = g(mid).0;
        if gm == 0.0 {
            return mid;
        }
        // A value that is not a number counts as past the root: the bracket shrinks towards
        // where the law is defined.
        if gm.is_finite() && (gm > 0.0) == (ga > 0.0) {
            a = mid;
            ga = gm;
        } else {
            b = mid;
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cubic(target: f64) -> impl FnMut(f64) -> (f64, f64) {
        move |z| (40.0 * z + 400.0 * z.powi(3) - target, 40.0 + 1200.0 * z * z)
    }

    #[test]
    fn newton_finds_a_cubic_springs_stretch_from_the_last_one() {
        let mut finder = RootFinder::new();
        for k in 0..100 {
            let target = 50.0 * (0.1 * f64::from(k)).sin();
            let z = finder.solve(cubic(target)).expect("a root");
            assert!(
                (40.0 * z + 400.0 * z.powi(3) - target).abs() < 1e-10,
                "{k}: {z}"
            );
        }
        assert_eq!(finder.failures(), 0);
    }

    /// A slope of zero at the start (x³ − 8 from 0) stops Newton; the bracket finds 2.
    #[test]
    fn a_flat_start_falls_back_to_bisection() {
        let mut finder = RootFinder::new();
        let z = finder
            .solve(|z| (z.powi(3) - 8.0, 3.0 * z * z))
            .expect("a root");
        assert!((z - 2.0).abs() < 1e-12, "{z}");
    }

    /// Where the law has no root (exp(z) = −1), the sample is said to have none, and the
    /// next starts from the last root found.
    #[test]
    fn no_root_is_reported_not_guessed() {
        let mut finder = RootFinder::new();
        assert!(finder.solve(|z| (z.exp() - 2.0, z.exp())).is_some());
        let last = finder.last();
        assert_eq!(finder.solve(|z| (z.exp() + 1.0, z.exp())), None);
        assert_eq!(finder.failures(), 1);
        assert_eq!(finder.last(), last);
    }

    /// A law defined on one side only (sqrt) is bracketed towards where it is defined.
    #[test]
    fn a_law_with_a_domain_is_bisected_inside_it() {
        let mut finder = RootFinder::new();
        // z + sqrt(z) = 6 at z = 4, from a start where Newton's first step leaves the domain.
        let z = finder
            .solve(|z| (z + z.sqrt() - 6.0, 1.0 + 0.5 / z.sqrt()))
            .expect("a root");
        assert!((z - 4.0).abs() < 1e-12, "{z}");
    }
}
