//! Rows of weights over a sliding window: the estimators that are fits (Savitzky–Golay,
//! modulating functions) give each derivative as one weighted sum of the last samples.

use crate::prelude::*;

use crate::window::Window;

/// One row of weights per derivative order, applied to the last `window` samples.
#[derive(Clone, Debug)]
pub(crate) struct Fir {
    /// `weights[k·window + j]`: the k-th derivative's weight of the j-th oldest sample, one
    /// flat array so that a sample's estimates read one block of memory.
    weights: Vec<f64>,
    window: usize,
    samples: Window<f64>,
    out: Vec<f64>,
    /// The samples before a slice, then the slice, as one run (reused between slices).
    joined: Vec<f64>,
}

impl Fir {
    /// The filter of `weights`, `window` per order, orders 0 to `order`.
    pub(crate) fn new(weights: Vec<f64>, window: usize, order: u32) -> Fir {
        Fir {
            weights,
            window,
            samples: Window::new(window, 0.0),
            out: vec![0.0; order as usize + 1],
            joined: Vec::new(),
        }
    }

    /// The weights of order `k`, oldest sample first.
    pub(crate) fn row(&self, k: u32) -> Option<&[f64]> {
        let start = k as usize * self.window;
        self.weights.get(start..start + self.window)
    }

    /// The highest order estimated.
    pub(crate) fn order(&self) -> u32 {
        self.out.len() as u32 - 1
    }

    /// Takes the next sample; once the window is full, the estimates by order.
    pub(crate) fn push(&mut self, x: f64) -> Option<&[f64]> {
        let window = self.window;
        let samples = self.samples.push(x)?;
        // Rows by offset, not `chunks_exact`, whose count costs an integer division.
        let mut row = 0;
        for out in &mut self.out {
            *out = dot(samples, &self.weights[row..row + window]);
            row += window;
        }
        Some(&self.out)
    }

    /// [`Fir::push`] of each of `xs` in turn, the estimate of order `k` after sample `i`
    /// written to `out[k·xs.len() + i]`; how many of the first samples gave none (their
    /// entries are left as they were). Same sums, in the same order, as `push`: the same
    /// estimates to the bit, several outputs at a time.
    pub(crate) fn push_slice(&mut self, xs: &[f64], out: &mut [f64]) -> usize {
        let (w, n) = (self.window, xs.len());
        let skip = (w - 1).saturating_sub(self.samples.seen()).min(n);
        self.joined.clear();
        self.joined.extend_from_slice(self.samples.last(w - 1));
        self.joined.extend_from_slice(xs);
        // Sample i of `xs` is `joined[w − 1 + i]`: its window starts at `joined[i]`.
        for (k, column) in out.chunks_exact_mut(n).enumerate().take(self.out.len()) {
            let weights = &self.weights[k * w..(k + 1) * w];
            let mut i = skip;
            while i + LANES <= n {
                let sums = dot_lanes(&self.joined[i..i + w + LANES - 1], weights);
                column[i..i + LANES].copy_from_slice(&sums);
                i += LANES;
            }
            for (to, start) in column[i..].iter_mut().zip(i..) {
                *to = dot(&self.joined[start..start + w], weights);
            }
        }
        self.samples.extend(xs);
        skip
    }
}

/// How many neighbouring outputs [`dot_lanes`] computes together.
const LANES: usize = 4;

/// `Σ aᵢ bᵢ` with four running sums: independent additions keep the floating-point unit
/// busy where one sum would wait on each addition.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0f64; 4];
    let (a4, a_rest) = a.split_at(a.len() / 4 * 4);
    let (b4, b_rest) = b.split_at(a4.len().min(b.len()));
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for k in 0..4 {
            sums[k] += x[k] * y[k];
        }
    }
    let rest: f64 = a_rest.iter().zip(b_rest).map(|(x, y)| x * y).sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + rest
}

/// [`dot`] of `weights` with each of the [`LANES`] windows that start in turn at the
/// beginning of `run` (`weights.len() + LANES − 1` samples): the same additions in the same
/// order for each, with the lanes side by side so that they run as vector arithmetic.
#[inline]
fn dot_lanes(run: &[f64], weights: &[f64]) -> [f64; LANES] {
    let w = weights.len();
    let whole = w / 4 * 4;
    let mut sums = [[0.0f64; LANES]; 4];
    for j in (0..whole).step_by(4) {
        for (k, sum) in sums.iter_mut().enumerate() {
            let weight = weights[j + k];
            let x = &run[j + k..j + k + LANES];
            for lane in 0..LANES {
                sum[lane] += x[lane] * weight;
            }
        }
    }
    core::array::from_fn(|lane| {
        let rest: f64 = (whole..w).map(|j| run[j + lane] * weights[j]).sum();
        (sums[0][lane] + sums[1][lane]) + (sums[2][lane] + sums[3][lane]) + rest
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Slices of every length, cut anywhere (within the first window too), give what the
    /// same samples pushed one at a time give, to the bit.
    #[test]
    fn slices_give_the_estimates_of_single_samples_to_the_bit() {
        for window in [3usize, 4, 5, 8, 11, 13] {
            let weights: Vec<f64> = (0..3 * window).map(|j| (j as f64 * 0.37).sin()).collect();
            let xs: Vec<f64> = (0..200).map(|k| (k as f64 * 0.05).cos() * 3.0).collect();
            let mut one = Fir::new(weights.clone(), window, 2);
            let single: Vec<Option<Vec<f64>>> = xs
                .iter()
                .map(|&x| one.push(x).map(<[f64]>::to_vec))
                .collect();
            for cut in [1usize, 2, 5, 7, 64, 200] {
                let mut many = Fir::new(weights.clone(), window, 2);
                for (c, chunk) in xs.chunks(cut).enumerate() {
                    let mut out = vec![f64::NAN; 3 * chunk.len()];
                    let skip = many.push_slice(chunk, &mut out);
                    for (i, expected) in single[c * cut..][..chunk.len()].iter().enumerate() {
                        let got: Option<Vec<f64>> =
                            (i >= skip).then(|| (0..3).map(|k| out[k * chunk.len() + i]).collect());
                        let bits = |v: &Option<Vec<f64>>| {
                            v.as_ref()
                                .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                        };
                        assert_eq!(bits(&got), bits(expected), "window {window}, cut {cut}");
                    }
                }
            }
        }
    }
}
