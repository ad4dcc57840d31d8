//! The little dense linear algebra identification needs: a symmetric eigendecomposition
//! (cyclic Jacobi) of matrices the size of a model's parameter list, and the products
//! around it. Jacobi is slow for large matrices but exact to rounding in every eigenvector,
//! which is what naming an undetermined combination of parameters takes.

/// A square matrix, row-major.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Square {
    pub(crate) n: usize,
    pub(crate) a: Vec<f64>,
}

impl Square {
    /// The `n × n` zero matrix.
    pub(crate) fn zeros(n: usize) -> Square {
        Square {
            n,
            a: vec![0.0; n * n],
        }
    }

    /// Entry `(i, j)`.
    pub(crate) fn at(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.n + j]
    }

    /// Adds `w · x xᵀ`.
    pub(crate) fn add_outer(&mut self, x: &[f64], w: f64) {
        if self.n == 0 {
            return;
        }
        for (row, xi) in self.a.chunks_exact_mut(self.n).zip(x) {
            let wi = w * xi;
            if wi == 0.0 {
                continue;
            }
            for (a, xj) in row.iter_mut().zip(x) {
                *a += wi * xj;
            }
        }
    }
}

/// The eigenvalues (descending) and unit eigenvectors (`vectors[k]` for `values[k]`) of the
/// symmetric matrix `m`.
pub(crate) fn eigen_symmetric(m: &Square) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = m.n;
    let mut a = m.a.clone();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    // Each sweep at least squares the off-diagonal mass's decay; 100 sweeps bound the loop.
    for _ in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j] * a[i * n + j])
            .sum();
        let diagonal: f64 = (0..n).map(|i| a[i * n + i] * a[i * n + i]).sum();
        if off <= 1e-30 * diagonal || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                rotate(&mut a, &mut v, n, p, q);
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| a[j * n + j].total_cmp(&a[i * n + i]));
    let values = order.iter().map(|&i| a[i * n + i]).collect();
    let vectors = (order.iter())
        .map(|&k| (0..n).map(|i| v[i * n + k]).collect())
        .collect();
    (values, vectors)
}

/// One Jacobi rotation zeroing `a[p][q]`, accumulated into the eigenvectors `v`.
fn rotate(a: &mut [f64], v: &mut [f64], n: usize, p: usize, q: usize) {
    let apq = a[p * n + q];
    if apq == 0.0 {
        return;
    }
    let app = a[p * n + p];
    let aqq = a[q * n + q];
    let theta = (aqq - app) / (2.0 * apq);
    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
    let t = if theta == 0.0 { 1.0 } else { t };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    for k in 0..n {
        let akp = a[k * n + p];
        let akq = a[k * n + q];
        a[k * n + p] = c * akp - s * akq;
        a[k * n + q] = s * akp + c * akq;
    }
    for k in 0..n {
        let apk = a[p * n + k];
        let aqk = a[q * n + k];
        a[p * n + k] = c * apk - s * aqk;
        a[q * n + k] = s * apk + c * aqk;
    }
    for k in 0..n {
        let vkp = v[k * n + p];
        let vkq = v[k * n + q];
        v[k * n + p] = c * vkp - s * vkq;
        v[k * n + q] = s * vkp + c * vkq;
    }
}

/// `x · y`.
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenpairs_rebuild_the_matrix_and_are_orthonormal() {
        let m = Square {
            n: 3,
            a: vec![4.0, 1.0, 2.0, 1.0, 3.0, 0.5, 2.0, 0.5, 1.0],
        };
        let (values, vectors) = eigen_symmetric(&m);
        assert!(values.windows(2).all(|w| w[0] >= w[1]));
        for i in 0..3 {
            for j in 0..3 {
                let rebuilt: f64 = (0..3)
                    .map(|k| values[k] * vectors[k][i] * vectors[k][j])
                    .sum();
                assert!((rebuilt - m.at(i, j)).abs() < 1e-12, "{i} {j}");
                let inner = dot(&vectors[i], &vectors[j]);
                assert!((inner - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_rank_deficient_matrix_has_a_zero_eigenvalue_along_its_null_direction() {
        // x xᵀ + y yᵀ with x = (1, 1, 0), y = (0, 1, 1): the null direction is (1, -1, 1).
        let mut m = Square::zeros(3);
        m.add_outer(&[1.0, 1.0, 0.0], 1.0);
        m.add_outer(&[0.0, 1.0, 1.0], 1.0);
        let (values, vectors) = eigen_symmetric(&m);
        assert!(values[2].abs() < 1e-14);
        let null = &vectors[2];
        let expected = [1.0, -1.0, 1.0].map(|x: f64| x / 3f64.sqrt());
        let sign = null[0].signum();
        for (a, b) in null.iter().zip(expected) {
            assert!((sign * a - b).abs() < 1e-12);
        }
    }
}
