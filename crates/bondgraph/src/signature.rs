//! One row of a fault signature matrix, sparse: the residuals a fault moves, by index.
//!
//! A row holds as many flags as there are residuals, most of them 0 on a large plant: a
//! generated matrix written densely grew with the square of the model (at 3,000 stages, 54 MB
//! of Rust and 3 GB of memory to write it). The marks alone grow with what the matrix says,
//! and the decisions read only the residuals in alarm and the marks.

use crate::prelude::*;

/// The residuals a fault of one component moves, out of all the residuals of a matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Signature<'a> {
    residuals: usize,
    marks: &'a [u32],
}

impl<'a> Signature<'a> {
    /// The signature marking `marks` (residual indices, strictly increasing, each below
    /// `residuals`) out of `residuals` residuals. Panics otherwise; in a `const` that is a
    /// compile error.
    #[must_use]
    pub const fn new(residuals: usize, marks: &'a [u32]) -> Signature<'a> {
        let mut k = 0;
        while k < marks.len() {
            assert!(
                (marks[k] as usize) < residuals,
                "a mark is not a residual of the matrix"
            );
            assert!(
                k == 0 || marks[k - 1] < marks[k],
                "marks must be strictly increasing"
            );
            k += 1;
        }
        Signature { residuals, marks }
    }

    /// How many residuals the matrix has (marked or not).
    #[must_use]
    pub const fn residuals(&self) -> usize {
        self.residuals
    }

    /// The marked residuals, ascending.
    pub fn marks(&self) -> impl ExactSizeIterator<Item = usize> + Clone + 'a {
        self.marks.iter().map(|&k| k as usize)
    }

    /// How many residuals are marked.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.marks.len()
    }

    /// No residual is marked: the fault is not detectable.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.marks.is_empty()
    }

    /// Whether residual `k` is marked.
    #[must_use]
    pub fn contains(&self, k: usize) -> bool {
        u32::try_from(k).is_ok_and(|k| self.marks.binary_search(&k).is_ok())
    }

    /// One flag per residual.
    #[must_use]
    pub fn to_dense(&self) -> Vec<bool> {
        let mut dense = vec![false; self.residuals];
        for k in self.marks() {
            dense[k] = true;
        }
        dense
    }

    /// The marks that are also in `on` (ascending residual indices): their count, and the
    /// indices of `on` that are not marked.
    pub(crate) fn meet<'o>(
        &self,
        on: &'o [usize],
    ) -> (usize, impl Iterator<Item = usize> + use<'o, 'a>) {
        let common = on.iter().filter(|&&k| self.contains(k)).count();
        let marks = *self;
        (
            common,
            on.iter().copied().filter(move |&k| !marks.contains(k)),
        )
    }
}

/// The residuals in alarm, ascending.
pub(crate) fn raised(alarms: &[bool]) -> Vec<usize> {
    (alarms.iter().enumerate())
        .filter(|&(_, &a)| a)
        .map(|(k, _)| k)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: Signature<'static> = Signature::new(5, &[1, 3]);

    #[test]
    fn a_signature_marks_its_residuals_out_of_all() {
        assert_eq!(S.residuals(), 5);
        assert_eq!(S.len(), 2);
        assert!(S.contains(3) && !S.contains(2) && !S.contains(9));
        assert_eq!(S.to_dense(), [false, true, false, true, false]);
        assert_eq!(S.marks().collect::<Vec<_>>(), [1, 3]);
        let (common, unmarked) = S.meet(&[0, 3, 4]);
        assert_eq!((common, unmarked.collect::<Vec<_>>()), (1, vec![0, 4]));
    }

    #[test]
    #[should_panic(expected = "strictly increasing")]
    fn marks_out_of_order_are_refused() {
        let _ = Signature::new(5, &[3, 1]);
    }

    #[test]
    #[should_panic(expected = "not a residual")]
    fn a_mark_past_the_residuals_is_refused() {
        let _ = Signature::new(2, &[2]);
    }
}
