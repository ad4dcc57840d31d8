//! Whether the copy of the model that simulated residuals run forgets where it started: its
//! linearisation at rest, and the Routh–Hurwitz test of its characteristic polynomial.
//!
//! A simulated residual compares a measured signal with a copy of the model run from rest on
//! the recorded inputs. If the record does not start at rest, or the copy's parameters are not
//! exactly the plant's, the copy starts off; where every mode of the copy decays, that error
//! dies out, and the residual holds after a transient. Where one does not (a free inertia, an
//! integrator, an unstable mode), the error stays or grows, and the residual is only right on
//! records that start at rest.

use super::{CopyState, Leaf, Program};
use crate::index::Idx as _;
use crate::symbolic::{Derivatives, Evaluator};

/// What the test says of the copy, linearised at rest (states and inputs zero).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stability {
    /// Every mode decays: an initial error dies out.
    Decays,
    /// Every mode decays but those of combinations of states the copy conserves whatever its
    /// inputs (a quantity it holds twice: the bench's twist, as the link's state and as its
    /// encoders' integrals; a position measured beside a spring's stretch). An error in their
    /// start stays as it is, neither dying out nor growing; from rest there is none, and a
    /// parameter's error never makes one.
    Conserved,
    /// Some mode does not decay (an eigenvalue with a real part of zero or more), and the
    /// inputs or the other states drive it: an error in the start or in a parameter stays
    /// or grows (a free inertia's position drifts).
    Persists,
    /// The linearisation could not be evaluated (a value that is not finite at rest).
    Unknown,
}

impl Stability {
    /// What it means for a simulated residual, as the outputs say it.
    pub fn meaning(self) -> &'static str {
        match self {
            Stability::Decays => {
                "linearised at rest, every mode of the copy decays: an error in its start dies out"
            }
            Stability::Conserved => {
                "linearised at rest, every mode of the copy decays but for quantities it holds \
                 twice and conserves (their rates cancel whatever the inputs): an error in their \
                 start stays as it is, so the residual holds on records that start as the model \
                 does in them (at rest), and an error of a parameter never moves them"
            }
            Stability::Persists => {
                "linearised at rest, a mode of the copy does not decay: an error in its start \
                 stays, and the residual holds only on records that start as the model does, at \
                 rest with every integral at zero"
            }
            Stability::Unknown => {
                "the copy cannot be linearised at rest, where a derivative is not finite: \
                 whether an error in its start dies out is not known"
            }
        }
    }
}

impl Program {
    /// Whether the copy of the model forgets its initial error, linearised at rest with the
    /// parameters `params` (in the model's order); `None` when no residual runs a copy.
    pub fn copy_stability(&self, params: &[f64]) -> Option<Stability> {
        let copy = self.copy.as_ref()?;
        let n = copy.rates.len();
        let mut pool = self.code.clone();
        let states: Vec<Leaf> = (0..n).map(|j| Leaf::State(CopyState::new(j))).collect();
        let drives: Vec<Leaf> = (0..copy.inputs.len())
            .map(|j| Leaf::Input(super::CopyInput::new(j)))
            .collect();
        let (Some(jacobian), Some(inputs)) = (
            rest_partials(&mut pool, &copy.rates, &states, params),
            rest_partials(&mut pool, &copy.rates, &drives, params),
        ) else {
            return Some(Stability::Unknown);
        };
        if (jacobian.iter().chain(&inputs).flatten()).any(|v| !v.is_finite()) {
            return Some(Stability::Unknown);
        }
        // A combination `w` of states with `wᵀA = 0` and `wᵀB = 0` is conserved: it is a
        // mode at zero that nothing drives. Each such independent combination is one root at
        // zero of the characteristic polynomial, taken out before the Routh test.
        let stacked: Vec<Vec<f64>> = (jacobian.iter().zip(&inputs))
            .map(|(a, b)| a.iter().chain(b).copied().collect())
            .collect();
        // Likewise a direction `v` with `Av = 0` that no simulated slot reads moves nothing
        // the residuals see (the bench's two encoder integrals moved together, the twist
        // unchanged): a mode at zero of no consequence.
        let mut observed = jacobian.clone();
        for slot in self.slots.values() {
            if let super::Fill::Simulated(k) = slot.fill {
                let mut row = vec![0.0; n];
                if let Some(x) = row.get_mut(k.index()) {
                    *x = 1.0;
                }
                observed.push(row);
            }
        }
        let conserved = (n - rank(&stacked)) + (n - rank(&observed));
        let polynomial = characteristic(&jacobian);
        let scale = polynomial.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let at_zero = (polynomial.iter())
            .take_while(|v| v.abs() <= 1e-9 * scale.max(f64::MIN_POSITIVE))
            .count();
        let removed = conserved.min(at_zero);
        Some(match hurwitz(&polynomial[removed..]) {
            true if removed > 0 => Stability::Conserved,
            true => Stability::Decays,
            false => Stability::Persists,
        })
    }
}

/// The partial derivatives of each of `rates` (rows) with respect to each of `leaves`
/// (columns), at rest (every leaf but the parameters at 0); `None` where one cannot be
/// taken.
fn rest_partials(
    pool: &mut crate::symbolic::Pool<Leaf>,
    rates: &[super::Code],
    leaves: &[Leaf],
    params: &[f64],
) -> Option<Vec<Vec<f64>>> {
    let mut out = vec![vec![0.0; leaves.len()]; rates.len()];
    for (j, &column) in leaves.iter().enumerate() {
        let mut partial = Derivatives::partial(|p: &mut crate::symbolic::Pool<Leaf>, leaf| {
            Some(p.num(if leaf == column { 1.0 } else { 0.0 }))
        });
        for (i, &rate) in rates.iter().enumerate() {
            let d = partial.of(pool, rate)?;
            out[i][j] = Evaluator::new(pool, |leaf| match leaf {
                Leaf::Parameter(p) => params[p.index()],
                _ => 0.0,
            })
            .value(d);
        }
    }
    Some(out)
}

/// The rank of a matrix (rows of equal length), by Gaussian elimination with partial
/// pivoting; a pivot below 1e-9 of the largest entry counts as zero.
fn rank(rows: &[Vec<f64>]) -> usize {
    let mut a: Vec<Vec<f64>> = rows.to_vec();
    let width = a.first().map_or(0, Vec::len);
    let largest = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let tiny = 1e-9 * largest.max(f64::MIN_POSITIVE);
    let mut rank = 0;
    for column in 0..width {
        let Some(pivot) =
            (rank..a.len()).max_by(|&i, &j| a[i][column].abs().total_cmp(&a[j][column].abs()))
        else {
            break;
        };
        if a[pivot][column].abs() <= tiny {
            continue;
        }
        a.swap(rank, pivot);
        let (done, below) = a.split_at_mut(rank + 1);
        let top = &done[rank];
        for row in below {
            let f = row[column] / top[column];
            for (x, t) in row.iter_mut().zip(top).skip(column) {
                *x -= f * t;
            }
        }
        rank += 1;
    }
    rank
}

/// The characteristic polynomial `det(λI − A)` of a square matrix, as `[c₀, …, cₙ = 1]`
/// (Faddeev–LeVerrier: exact in exact arithmetic, and well enough for the few states of a
/// model).
fn characteristic(a: &[Vec<f64>]) -> Vec<f64> {
    let n = a.len();
    let mut c = vec![0.0; n + 1];
    c[n] = 1.0;
    let mut m = vec![vec![0.0; n]; n];
    for k in 1..=n {
        // M_k = A M_{k−1} + c_{n−k+1} I, then c_{n−k} = −tr(A M_k)/k.
        let mut next = vec![vec![0.0; n]; n];
        for (i, row) in next.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..n).map(|l| a[i][l] * m[l][j]).sum::<f64>();
            }
            row[i] += c[n - k + 1];
        }
        m = next;
        let trace: f64 = (0..n)
            .map(|i| (0..n).map(|l| a[i][l] * m[l][i]).sum::<f64>())
            .sum();
        c[n - k] = -trace / k as f64;
    }
    c
}

/// Whether every root of `c₀ + c₁ λ + … + cₙ λⁿ` (with `cₙ > 0`) has a negative real part: the
/// first column of the Routh array is positive. Coefficients below a millionth of the largest
/// count as zero, so that a mode at zero (a free integrator) is not taken for a slow decay.
fn hurwitz(c: &[f64]) -> bool {
    let scale = c.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tiny = 1e-9 * scale.max(f64::MIN_POSITIVE);
    // Highest power first.
    let coefficients: Vec<f64> = c.iter().rev().copied().collect();
    if coefficients.iter().any(|&v| v <= tiny) {
        return false;
    }
    let mut rows: [Vec<f64>; 2] = [
        coefficients.iter().step_by(2).copied().collect(),
        coefficients.iter().skip(1).step_by(2).copied().collect(),
    ];
    for _ in 2..coefficients.len() {
        let (upper, lower) = (&rows[0], &rows[1]);
        let Some(&pivot) = lower.first() else { break };
        if pivot <= tiny {
            return false;
        }
        let next: Vec<f64> = (0..upper.len().saturating_sub(1))
            .map(|k| {
                let below = lower.get(k + 1).copied().unwrap_or(0.0);
                upper[k + 1] - upper[0] * below / pivot
            })
            .collect();
        rows = [rows[1].clone(), next];
    }
    rows[1].first().is_none_or(|&v| v > tiny) && rows[0].first().is_some_and(|&v| v > tiny)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{compile, Options, ResidualSet};

    fn stability(text: &str) -> Option<Stability> {
        let options = Options {
            residuals: ResidualSet::Best,
            ..Options::default()
        };
        let c = compile(text, "test.bg", &options).expect("valid").compiled;
        let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
        c.program().copy_stability(&params)
    }

    /// The bench's copy holds the twist twice, as the link's state and as `int(y1) − N
    /// int(y2)` in the dead zone: their difference is conserved (a mode at zero nothing
    /// drives), and the two integrals moved together leave the twist as it is (a mode at
    /// zero nothing reads); every other mode decays. Two tanks
    /// joined by a smoothed valve (`tanh(e)·sqrt(|e|)`, which has no closed-form inverse, so
    /// a copy measures the first level) have no finite slope at rest. A model whose
    /// residuals need no copy has none.
    #[test]
    fn the_copies_of_the_models_are_told_apart() {
        let bench = include_str!("../../../../models/backlash_bench.bg");
        assert_eq!(stability(bench), Some(Stability::Conserved));
        let tanks = include_str!("../../../../models/two_tank.bg");
        let valve = "f = Cd12*sign(e)*sqrt(abs(e))";
        assert!(tanks.contains(valve));
        let smoothed = tanks.replace(valve, "f = Cd12*tanh(e/100)*sqrt(abs(e))");
        assert_eq!(stability(&smoothed), Some(Stability::Unknown));
        let motor = include_str!("../../../../models/dc_motor.bg");
        assert_eq!(stability(motor), None);
    }

    /// Hand-checked polynomials: (λ+1)(λ+2)(λ+3) decays; λ(λ+1) and (λ−1)(λ+2) do not;
    /// λ² + 1 (an undamped oscillator) does not.
    #[test]
    fn the_routh_test_tells_decaying_polynomials() {
        assert!(hurwitz(&[6.0, 11.0, 6.0, 1.0]));
        assert!(!hurwitz(&[0.0, 1.0, 1.0]));
        assert!(!hurwitz(&[-2.0, 1.0, 1.0]));
        assert!(!hurwitz(&[1.0, 0.0, 1.0]));
        // λ⁴ + λ³ + λ² + λ + 1: all coefficients positive, roots on the right of the axis.
        assert!(!hurwitz(&[1.0, 1.0, 1.0, 1.0, 1.0]));
        assert!(hurwitz(&[2.0, 3.0, 1.0]));
    }

    /// A free mass driven by a force, its position measured: the position's mode is driven
    /// and drifts. The same mass on a spring, its position measured beside the spring's
    /// stretch: the two integrate the same speed, and their difference is conserved.
    #[test]
    fn a_driven_integrator_persists_and_a_quantity_held_twice_is_conserved() {
        let free = "model m\nparam M = 2\nparam b = 1\ninput F\nSe f = F\nI m = M\n\
                    R d = b\nDq x on v\nf -> 1:v -> m, d\n";
        let options = Options {
            residuals: ResidualSet::Simulated,
            ..Options::default()
        };
        let at = |text: &str| {
            let c = compile(text, "test.bg", &options).expect("valid").compiled;
            let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
            c.program().copy_stability(&params)
        };
        assert_eq!(at(free), Some(Stability::Persists));
        let spring = free
            .replace("R d = b\n", "R d = b\nC k = 0.5\n")
            .replace("m, d", "m, d, k");
        assert_eq!(at(&spring), Some(Stability::Conserved));
        assert_eq!(rank(&[vec![1.0, 2.0], vec![2.0, 4.0]]), 1);
        assert_eq!(rank(&[vec![1.0, 0.0, 1.0], vec![0.0, 1.0, 0.0]]), 2);
    }

    /// The characteristic polynomial of a companion matrix is the one it was built from.
    #[test]
    fn the_characteristic_polynomial_of_a_companion_matrix() {
        let a = vec![
            vec![0.0, 1.0, 0.0],
            vec![0.0, 0.0, 1.0],
            vec![-6.0, -11.0, -6.0],
        ];
        let c = characteristic(&a);
        for (got, want) in c.iter().zip([6.0, 11.0, 6.0, 1.0]) {
            assert!((got - want).abs() < 1e-12, "{c:?}");
        }
    }
}
