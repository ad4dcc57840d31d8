//! Monomials: atoms with integer exponents, stored inline when short.

use std::cmp::Ordering;
use std::hash::{Hash, Hasher};
use std::ops::{Deref, DerefMut};

use super::pool::ExprId;

/// How many factors a monomial holds without allocating. Most terms of a model's
/// expressions have three or fewer (`K * j0 * y1`); the canonical forms of a large model
/// hold millions of them, and one allocation each dominated building and freeing them.
const INLINE: usize = 3;

/// Atoms with their (non-zero) integer exponents, sorted by atom. Compares, orders and
/// hashes as the slice of its factors.
#[derive(Clone, Debug)]
pub(crate) enum Monomial {
    /// Up to [`INLINE`] factors, the first `len` of `factors` used.
    Inline {
        /// How many of `factors` are used.
        len: u8,
        /// The factors.
        factors: [(ExprId, i32); INLINE],
    },
    /// More factors.
    Heap(Vec<(ExprId, i32)>),
}

impl Default for Monomial {
    fn default() -> Self {
        Monomial::Inline {
            len: 0,
            factors: [(ExprId::from_index(0), 0); INLINE],
        }
    }
}

impl Monomial {
    /// The monomial 1.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// A monomial with room for `n` factors.
    pub(crate) fn with_capacity(n: usize) -> Self {
        if n <= INLINE {
            Self::default()
        } else {
            Monomial::Heap(Vec::with_capacity(n))
        }
    }

    /// Appends a factor (the caller keeps the order).
    pub(crate) fn push(&mut self, factor: (ExprId, i32)) {
        match self {
            Monomial::Inline { len, factors } if usize::from(*len) < INLINE => {
                factors[usize::from(*len)] = factor;
                *len += 1;
            }
            Monomial::Inline { len, factors } => {
                let mut v = factors[..usize::from(*len)].to_vec();
                v.push(factor);
                *self = Monomial::Heap(v);
            }
            Monomial::Heap(v) => v.push(factor),
        }
    }

    /// Removes the factor at `i`.
    pub(crate) fn remove(&mut self, i: usize) {
        match self {
            Monomial::Inline { len, factors } => {
                factors.copy_within(i + 1..usize::from(*len), i);
                *len -= 1;
            }
            Monomial::Heap(v) => {
                v.remove(i);
            }
        }
    }
}

impl Deref for Monomial {
    type Target = [(ExprId, i32)];

    fn deref(&self) -> &Self::Target {
        match self {
            Monomial::Inline { len, factors } => &factors[..usize::from(*len)],
            Monomial::Heap(v) => v,
        }
    }
}

impl DerefMut for Monomial {
    fn deref_mut(&mut self) -> &mut Self::Target {
        match self {
            Monomial::Inline { len, factors } => &mut factors[..usize::from(*len)],
            Monomial::Heap(v) => v,
        }
    }
}

impl FromIterator<(ExprId, i32)> for Monomial {
    fn from_iter<I: IntoIterator<Item = (ExprId, i32)>>(iter: I) -> Self {
        let mut m = Monomial::new();
        m.extend(iter);
        m
    }
}

impl Extend<(ExprId, i32)> for Monomial {
    fn extend<I: IntoIterator<Item = (ExprId, i32)>>(&mut self, iter: I) {
        for factor in iter {
            self.push(factor);
        }
    }
}

impl PartialEq for Monomial {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl Eq for Monomial {}

impl PartialOrd for Monomial {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Monomial {
    fn cmp(&self, other: &Self) -> Ordering {
        (**self).cmp(&**other)
    }
}

impl Hash for Monomial {
    fn hash<H: Hasher>(&self, state: &mut H) {
        (**self).hash(state);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_and_long_monomials_compare_as_their_factors() {
        let f = |k: u32| (ExprId::from_index(k), 1);
        let short: Monomial = [f(1), f(2)].into_iter().collect();
        let long: Monomial = (1..=5).map(f).collect();
        assert!(matches!(short, Monomial::Inline { len: 2, .. }));
        assert!(matches!(long, Monomial::Heap(_)));
        assert!(short < long);
        assert_eq!(
            short.cmp(&long),
            [f(1), f(2)][..].cmp(&(1..=5).map(f).collect::<Vec<_>>()[..])
        );
        let mut grown = short.clone();
        grown.extend([f(3), f(4), f(5)]);
        assert_eq!(grown, long);
        grown.remove(0);
        assert_eq!(&*grown, &(2..=5).map(f).collect::<Vec<_>>()[..]);
        let mut shrunk = short;
        shrunk.remove(0);
        assert_eq!(&*shrunk, &[f(2)][..]);
    }
}
