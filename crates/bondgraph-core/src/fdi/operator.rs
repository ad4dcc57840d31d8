//! Polynomials in `D` = d/dt whose coefficients are parameter expressions, and their
//! greatest common divisor.
//!
//! Eliminating `u` from `a(D) u + ra = 0` and `t(D) u + rt = 0` as `t ra − a rt = 0` applies
//! the whole of `a` and `t` where their least common multiple is enough: with
//! `g = gcd(a, t)`, `(t/g) ra − (a/g) rt = 0` is the same combination of the two equations
//! divided by nothing (`(t/g) a u = (a/g) t u`), so it holds exactly, for any initial state,
//! and needs `deg g` fewer derivatives of every signal it reads. A spring and a damper in
//! parallel (`b D + k`) met twice along a chain is such a factor.
//!
//! Coefficients are canonical polynomials over parameters with floating-point numbers, so a
//! cancellation may leave rounding: remainders are chopped relative to their largest term,
//! and a divisor is only used when it divides both operators exactly. When anything is in
//! doubt (a coefficient grows too large, no coefficient to normalise by), the factor is taken
//! as 1: the result is then what the plain product gives, never wrong.

use crate::symbolic::Polynomial;

/// `Σₖ c[k] Dᵏ`.
pub(super) type Operator = Vec<Polynomial>;

/// Terms a coefficient may reach during Euclid's algorithm before the search gives up.
const MAX_COEFFICIENT_TERMS: usize = 2_000;

/// What rounding may leave of a term that cancels, relative to the largest term.
const ROUNDING: f64 = 1e-12;

/// The degree of `a`, `None` when it is zero.
fn degree(a: &[Polynomial]) -> Option<usize> {
    a.iter().rposition(|c| !c.is_zero())
}

fn trimmed(mut a: Operator) -> Operator {
    for c in &mut a {
        c.chop(ROUNDING);
    }
    let len = degree(&a).map_or(0, |d| d + 1);
    a.truncate(len);
    a
}

/// The remainder of `a` by `b` (deg b ≥ 1), up to a factor free of `D`: a step divides by
/// `b`'s leading coefficient when it is one term, else multiplies `a` by it (pseudo-division).
fn remainder(mut a: Operator, b: &[Polynomial]) -> Option<Operator> {
    let db = degree(b)?;
    let lead = &b[db];
    while let Some(da) = degree(&a).filter(|&da| da >= db) {
        let shift = da - db;
        let top = a[da].clone();
        match top.over_monomial(lead) {
            Some(q) => {
                for (k, bk) in b.iter().enumerate().take(db) {
                    a[k + shift].add_scaled(&q.times(bk), -1.0);
                }
            }
            None => {
                for c in &mut a {
                    *c = c.times(lead);
                }
                for (k, bk) in b.iter().enumerate().take(db) {
                    a[k + shift].add_scaled(&top.times(bk), -1.0);
                }
            }
        }
        // Zero by construction, whatever rounding says.
        a[da] = Polynomial::default();
        a = trimmed(a);
        if a.iter().any(|c| c.terms() > MAX_COEFFICIENT_TERMS) {
            return None;
        }
    }
    Some(a)
}

/// `a / g` when `g` divides `a` exactly and `g`'s leading coefficient is one term.
pub(super) fn divide(a: &[Polynomial], g: &[Polynomial]) -> Option<Operator> {
    let dg = degree(g)?;
    let Some(da) = degree(a) else {
        return Some(Vec::new());
    };
    if da < dg {
        return None;
    }
    let mut rest: Operator = a[..=da].to_vec();
    let mut quotient = vec![Polynomial::default(); da - dg + 1];
    for shift in (0..=da - dg).rev() {
        let q = rest.get(shift + dg)?.over_monomial(&g[dg])?;
        for (k, gk) in g.iter().enumerate().take(dg) {
            rest[k + shift].add_scaled(&q.times(gk), -1.0);
        }
        rest[shift + dg] = Polynomial::default();
        quotient[shift] = q;
    }
    for c in &mut rest {
        c.chop(ROUNDING);
    }
    // The remainder is judged against the size of what was divided.
    let exact = rest.iter().all(Polynomial::is_zero);
    exact.then(|| trimmed(quotient))
}

/// `g` scaled so that its constant term is 1 (or, with no constant term, its leading
/// coefficient): dividing by it then keeps the scale of a relation's lowest derivatives, and
/// `(1 + b/k D)` is divided out without leaving `b/k` in front. `None` when the coefficient
/// to scale by is not one term, or when the leading coefficient is then not one term (the
/// division could not be done exactly).
fn monic(g: Operator) -> Option<Operator> {
    let dg = degree(&g)?;
    let by = if g[0].is_zero() { &g[dg] } else { &g[0] };
    let scaled: Operator = g
        .iter()
        .map(|c| c.over_monomial(by))
        .collect::<Option<_>>()?;
    scaled[dg].over_monomial(&scaled[dg])?;
    Some(scaled)
}

/// `a · b`.
pub(super) fn product(a: &[Polynomial], b: &[Polynomial]) -> Operator {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![Polynomial::default(); a.len() + b.len() - 1];
    for (i, ai) in a.iter().enumerate() {
        for (j, bj) in b.iter().enumerate() {
            out[i + j].add_scaled(&ai.times(bj), 1.0);
        }
    }
    trimmed(out)
}

/// `g` normalised as [`monic`] does: a candidate divisor.
pub(super) fn normalised(g: &[Polynomial]) -> Option<Operator> {
    monic(trimmed(g.to_vec())).filter(|g| degree(g).is_some_and(|d| d >= 1))
}

/// The product of the `candidates` (each monic) that divide both `a` and `b`, each as often
/// as it does; `None` when none does. This finds a common factor whose content in the
/// parameters is not one term, which Euclid's algorithm cannot normalise without a gcd of
/// multivariate polynomials: the factors an elimination produces are the operators it met.
pub(super) fn common_known_factor(
    a: &[Polynomial],
    b: &[Polynomial],
    candidates: &[Operator],
) -> Option<Operator> {
    let (mut a, mut b) = (trimmed(a.to_vec()), trimmed(b.to_vec()));
    let mut g: Option<Operator> = None;
    let mut by_degree: Vec<&Operator> = candidates.iter().collect();
    by_degree.sort_by_key(|f| f.len());
    for f in by_degree {
        while let (Some(qa), Some(qb)) = (divide(&a, f), divide(&b, f)) {
            (a, b) = (qa, qb);
            g = Some(match g {
                Some(g) => product(&g, f),
                None => f.clone(),
            });
        }
    }
    g
}

/// A common divisor of `a` and `b` of degree ≥ 1 in `D`, monic, dividing both exactly; `None`
/// when they are coprime or when that cannot be established within the bounds.
pub(super) fn common_factor(a: &[Polynomial], b: &[Polynomial]) -> Option<Operator> {
    let (mut x, mut y) = (trimmed(a.to_vec()), trimmed(b.to_vec()));
    if degree(&x)? < degree(&y)? {
        std::mem::swap(&mut x, &mut y);
    }
    loop {
        match degree(&y) {
            None => break,
            Some(0) => return None,
            Some(_) => {
                let r = remainder(x, &y)?;
                x = y;
                y = r;
            }
        }
    }
    let g = monic(x)?;
    (degree(&g)? >= 1 && divide(a, &g).is_some() && divide(b, &g).is_some()).then_some(g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::ParamId;
    use crate::symbolic::{Leaf, Pool, Simplifier};

    struct Params {
        pool: Pool,
        simplifier: Simplifier,
    }

    impl Params {
        fn p(&mut self, i: u32) -> Polynomial {
            let leaf = self.pool.leaf(Leaf::Param(ParamId(i)));
            self.simplifier.polynomial(&mut self.pool, leaf)
        }
        fn n(&mut self, x: f64) -> Polynomial {
            let num = self.pool.num(x);
            self.simplifier.polynomial(&mut self.pool, num)
        }
    }

    fn params() -> Params {
        Params {
            pool: Pool::default(),
            simplifier: Simplifier::default(),
        }
    }

    /// `(b D + k)(m D² + d)` and `b D + k` share `1 + b/k D` (Euclid); with `(b D + k)(1 + c D)`
    /// Euclid's last remainder has a content that is a sum, so the factor is found among the
    /// operators met before; coprime operators share nothing.
    #[test]
    fn a_shared_spring_damper_factor_is_found_and_divided_out() {
        let mut s = params();
        let (b, k, m, d, c) = (s.p(0), s.p(1), s.p(2), s.p(3), s.p(4));
        let one = s.n(1.0);
        let zero = Polynomial::default();
        let spring = vec![k.clone(), b.clone()];
        let first = product(&spring, &[d.clone(), zero.clone(), m.clone()]);
        let second = product(&spring, &[one.clone(), c.clone()]);
        let g = common_factor(&first, &spring).expect("a common factor");
        assert_eq!(Some(g.clone()), normalised(&spring));
        assert_eq!(
            common_known_factor(&first, &second, std::slice::from_ref(&g)),
            Some(g.clone())
        );
        assert_eq!(
            common_known_factor(&first, &[one.clone(), c.clone()], std::slice::from_ref(&g)),
            None
        );
        assert_eq!(g.len(), 2);
        assert_eq!(g[0], one);
        assert_eq!(g[1], b.over_monomial(&k).expect("k is one term"));
        let q = divide(&first, &g).expect("exact");
        assert_eq!(
            q,
            product(std::slice::from_ref(&k), &[d.clone(), zero, m.clone()])
        );
        // A sum as leading coefficient: (m + c) D + k and (m + c) D² + d share nothing.
        let mc = m.plus(&c, 1.0);
        assert!(common_factor(&[k.clone(), mc.clone()], &[d, Polynomial::default(), mc]).is_none());
        // A non-divisor is refused.
        assert!(divide(&[k, one.clone()], &[b, one]).is_none());
    }
}
