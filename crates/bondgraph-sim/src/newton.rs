//! Newton's method for the unknowns of nonlinear algebraic loops, solved at every evaluation
//! of the state equations.

/// Most Newton iterations at one evaluation: from the last solution, a smooth loop takes
/// two or three.
const MAX_ITERATIONS: usize = 60;

/// Most halvings of a Newton step that does not reduce the residual.
const MAX_HALVINGS: usize = 30;

/// Why Newton's method stopped without a root.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct NoRoot {
    /// The largest |residual| where it stopped.
    pub residual: f64,
}

/// Solves `f(z) = 0` from the guess in `z`, which holds the root on success. `f` writes the
/// residuals of `z` into its second argument. The Jacobian is taken by forward differences
/// (a few unknowns: exact derivatives would not pay), and each step is halved until the
/// largest residual falls, so that a guess far from the root still converges.
pub(crate) fn solve(z: &mut [f64], mut f: impl FnMut(&[f64], &mut Vec<f64>)) -> Result<(), NoRoot> {
    let n = z.len();
    let mut r = Vec::with_capacity(n);
    let mut trial_r = Vec::with_capacity(n);
    let mut jacobian = vec![0.0; n * n];
    let mut trial = z.to_vec();
    f(z, &mut r);
    let mut norm = max_abs(&r);
    for _ in 0..MAX_ITERATIONS {
        if norm == 0.0 {
            return Ok(());
        }
        if !norm.is_finite() {
            break;
        }
        for j in 0..n {
            let delta = f64::EPSILON.sqrt() * z[j].abs().max(1.0);
            trial.copy_from_slice(z);
            trial[j] += delta;
            f(&trial, &mut trial_r);
            for i in 0..n {
                jacobian[i * n + j] = (trial_r[i] - r[i]) / delta;
            }
        }
        let Some(step) = linear_solve(&mut jacobian, &r) else {
            break;
        };
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..MAX_HALVINGS {
            for ((t, z), s) in trial.iter_mut().zip(z.iter()).zip(&step) {
                *t = z - lambda * s;
            }
            f(&trial, &mut trial_r);
            let trial_norm = max_abs(&trial_r);
            if trial_norm < norm {
                accepted = true;
                norm = trial_norm;
                break;
            }
            lambda *= 0.5;
        }
        let size = max_abs(&step) * lambda;
        let scale = max_abs(z).max(1.0);
        if !accepted {
            // No step reduces the residual: at a root to rounding, or stuck.
            return if size <= 1e-10 * scale {
                Ok(())
            } else {
                Err(NoRoot { residual: norm })
            };
        }
        z.copy_from_slice(&trial);
        std::mem::swap(&mut r, &mut trial_r);
        if size <= 1e-13 * scale {
            return Ok(());
        }
    }
    Err(NoRoot { residual: norm })
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(
        0.0,
        |m, x| if x.is_nan() { f64::NAN } else { m.max(x.abs()) },
    )
}

/// `A x = b` for a row-major `n × n` matrix, by elimination with partial pivoting; `None`
/// when `A` is singular.
fn linear_solve(a: &mut [f64], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut x = b.to_vec();
    for col in 0..n {
        let pivot =
            (col..n).max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))?;
        let size = a[pivot * n + col].abs();
        if size == 0.0 || size.is_nan() {
            return None;
        }
        if pivot != col {
            for k in 0..n {
                a.swap(col * n + k, pivot * n + k);
            }
            x.swap(col, pivot);
        }
        for row in col + 1..n {
            let factor = a[row * n + col] / a[col * n + col];
            for k in col..n {
                a[row * n + k] -= factor * a[col * n + k];
            }
            x[row] -= factor * x[col];
        }
    }
    for col in (0..n).rev() {
        let tail: f64 = (col + 1..n).map(|k| a[col * n + k] * x[k]).sum();
        x[col] = (x[col] - tail) / a[col * n + col];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cubic `(2 − z)³ = z/2 + z − 1` and a coupled pair, to rounding.
    #[test]
    fn newton_finds_roots_of_a_cubic_and_of_a_pair() {
        let mut z = [0.0];
        solve(&mut z, |z, r| {
            r.clear();
            r.push((2.0 - z[0]).powi(3) - 1.5 * z[0] + 1.0);
        })
        .expect("a root");
        assert!(
            ((2.0 - z[0]).powi(3) - 1.5 * z[0] + 1.0).abs() < 1e-12,
            "{z:?}"
        );
        // x² + y² = 4, x = y³: from far away.
        let mut z = [10.0, -3.0];
        solve(&mut z, |z, r| {
            r.clear();
            r.push(z[0] * z[0] + z[1] * z[1] - 4.0);
            r.push(z[0] - z[1] * z[1] * z[1]);
        })
        .expect("a root");
        assert!((z[0] * z[0] + z[1] * z[1] - 4.0).abs() < 1e-12, "{z:?}");
        assert!((z[0] - z[1].powi(3)).abs() < 1e-12, "{z:?}");
    }

    /// `z² + 1 = 0` has no real root: an error with the residual, not a hang.
    #[test]
    fn no_root_is_an_error() {
        let mut z = [0.3];
        let err = solve(&mut z, |z, r| {
            r.clear();
            r.push(z[0] * z[0] + 1.0);
        })
        .expect_err("no real root");
        assert!(err.residual >= 1.0, "{err:?}");
    }
}
