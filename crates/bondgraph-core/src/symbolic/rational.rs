//! Rational functions in lowest terms: one numerator over a product of sums, with every
//! factor that divides the numerator cancelled.
//!
//! The canonical form ([`super::normal`]) keeps a reciprocal of a sum as an atom, so the
//! solution of a linear algebraic loop, found one torn unknown at a time, comes out as
//! fractions nested in fractions (the Wheatstone bridge's state equations ran to thousands
//! of characters), and a factor common to a numerator and a denominator stays. Here each
//! such atom is opened: the expression becomes `N / (f1^k1 ... fn^kn)`, with `N` a polynomial
//! in the atoms and each `fi` a sum normalised (no monomial content, first term 1), put
//! over the least common multiple of the denominators it meets, and a factor is cancelled
//! whenever it divides `N` exactly (multivariate division in lexicographic order).
//!
//! Cancellation is by the factors that arise as denominators, not a full multivariate gcd:
//! enough for what elimination produces (a denominator that is also a factor of the
//! numerator), never wrong, since a factor is only removed when the division is exact.
//! Numbers are floating point: what rounding leaves of an exact cancellation is dropped
//! relative to the largest coefficient. Every polynomial is bounded by [`MAX_TERMS`]; past
//! it the form is not built and the caller keeps the canonical one.

use std::cmp::Ordering;

use super::hash::FastMap;
use super::monomial::Monomial;
use super::normal::{add_into, constant, mul, mul_monomials, rebuild, Poly, MAX_TERMS};
use super::pool::{ExprId, Node, Pool};
use super::Simplifier;
use crate::expr::BinOp;

/// What rounding may leave of a term that cancels, relative to the largest coefficient.
const ROUNDING: f64 = 1e-12;

/// `num / Π factor^k`.
#[derive(Clone, Debug)]
struct Rational {
    num: Poly,
    /// Normalised sums with their multiplicities (> 0), in the order first met.
    den: Vec<(Poly, u32)>,
}

impl Rational {
    fn of(num: Poly) -> Rational {
        Rational {
            num,
            den: Vec::new(),
        }
    }
}

/// Lexicographic order on monomials with non-negative exponents, the atom of smallest id
/// most significant: compatible with multiplication, as division needs.
fn lex(a: &Monomial, b: &Monomial) -> Ordering {
    let (mut i, mut j) = (0, 0);
    loop {
        match (a.get(i), b.get(j)) {
            (None, None) => return Ordering::Equal,
            (Some(_), None) => return Ordering::Greater,
            (None, Some(_)) => return Ordering::Less,
            (Some(&(x, ex)), Some(&(y, ey))) => match x.cmp(&y) {
                Ordering::Less => return Ordering::Greater,
                Ordering::Greater => return Ordering::Less,
                Ordering::Equal => match ex.cmp(&ey) {
                    Ordering::Equal => {
                        i += 1;
                        j += 1;
                    }
                    other => return other,
                },
            },
        }
    }
}

/// The monomial whose exponents are the least each atom has in `p` (0 for an atom missing
/// from some term), taken as most negative: `p / content` has non-negative exponents and
/// no monomial factor.
fn content(p: &Poly) -> Monomial {
    let mut least: Vec<(ExprId, i32)> = Vec::new();
    let mut first = true;
    for (m, _) in p.iter() {
        if first {
            least = m.iter().copied().collect();
            first = false;
            continue;
        }
        least.retain_mut(|(a, e)| match m.iter().find(|(b, _)| b == a) {
            Some(&(_, f)) => {
                *e = (*e).min(f);
                true
            }
            None => {
                // Missing: exponent 0 here, so only a negative exponent is kept.
                *e = (*e).min(0);
                *e != 0
            }
        });
    }
    // Atoms with negative exponents in some terms but absent from the first.
    for (m, _) in p.iter() {
        for &(a, e) in m.iter() {
            if e < 0 && !least.iter().any(|(b, _)| *b == a) {
                let low = p
                    .iter()
                    .map(|(n, _)| n.iter().find(|(b, _)| *b == a).map_or(0, |&(_, f)| f))
                    .min()
                    .unwrap_or(0);
                least.push((a, low));
            }
        }
    }
    least.sort_unstable();
    least.into_iter().collect()
}

fn inverse(m: &Monomial) -> Monomial {
    m.iter().map(|&(a, e)| (a, -e)).collect()
}

fn times_monomial(p: &Poly, m: &Monomial, c: f64) -> Poly {
    Poly::from_terms(
        p.iter()
            .map(|(n, d)| (mul_monomials(n, m), d * c))
            .collect(),
    )
}

/// `p = unit · f` with `f` free of monomial factors, non-negative exponents, first term 1.
fn normalise(p: &Poly) -> (Monomial, f64, Poly) {
    let m = content(p);
    let shifted = times_monomial(p, &inverse(&m), 1.0);
    let lead = shifted.iter().next().map_or(1.0, |(_, c)| *c);
    let f = times_monomial(&shifted, &Monomial::new(), 1.0 / lead);
    (m, lead, f)
}

fn chop(p: &mut Poly, scale: f64) {
    p.0.retain(|(_, c)| c.abs() > ROUNDING * scale);
}

/// `n / f` when `f` (normalised) divides `n` exactly.
fn exact_quotient(n: &Poly, f: &Poly) -> Option<Poly> {
    if n.is_empty() {
        return Some(Poly::default());
    }
    let shift = content(n);
    let mut rest = times_monomial(n, &inverse(&shift), 1.0);
    let scale = rest.iter().map(|(_, c)| c.abs()).fold(0.0, f64::max);
    let (lead_f, cf) = f
        .iter()
        .max_by(|a, b| lex(a.0, b.0))
        .map(|(m, c)| (m.clone(), *c))?;
    let mut quotient: Vec<(Monomial, f64)> = Vec::new();
    while let Some((lead_r, cr)) = rest
        .iter()
        .max_by(|a, b| lex(a.0, b.0))
        .map(|(m, c)| (m.clone(), *c))
    {
        let divisible = lead_f.iter().all(|&(a, e)| {
            lead_r
                .iter()
                .find(|(b, _)| *b == a)
                .is_some_and(|&(_, g)| g >= e)
        });
        if !divisible || quotient.len() >= MAX_TERMS {
            return None;
        }
        let q = mul_monomials(&lead_r, &inverse(&lead_f));
        let c = cr / cf;
        add_into(&mut rest, &times_monomial(f, &q, c), -1.0);
        rest.0.retain(|(m, _)| *m != lead_r);
        chop(&mut rest, scale);
        quotient.push((q, c));
    }
    Some(times_monomial(&Poly::from_terms(quotient), &shift, 1.0))
}

fn too_large(p: &Poly) -> bool {
    p.len() > MAX_TERMS
}

fn power(p: &Poly, k: u32) -> Option<Poly> {
    let mut out = constant(1.0);
    for _ in 0..k {
        out = mul(&out, p);
        if too_large(&out) {
            return None;
        }
    }
    Some(out)
}

impl Rational {
    /// Cancels every factor that divides the numerator, as often as it does.
    fn cancel(&mut self) {
        for (f, k) in &mut self.den {
            while *k > 0 {
                match exact_quotient(&self.num, f) {
                    Some(q) => {
                        self.num = q;
                        *k -= 1;
                    }
                    None => break,
                }
            }
        }
        self.den.retain(|(_, k)| *k > 0);
    }

    fn times(&self, other: &Rational) -> Option<Rational> {
        let num = mul(&self.num, &other.num);
        if too_large(&num) {
            return None;
        }
        let mut den = self.den.clone();
        for (f, k) in &other.den {
            match den.iter_mut().find(|(g, _)| g == f) {
                Some((_, j)) => *j += k,
                None => den.push((f.clone(), *k)),
            }
        }
        let mut out = Rational { num, den };
        out.cancel();
        Some(out)
    }

    fn plus(&self, other: &Rational) -> Option<Rational> {
        let mut den: Vec<(Poly, u32)> = self.den.clone();
        for (f, k) in &other.den {
            match den.iter_mut().find(|(g, _)| g == f) {
                Some((_, j)) => *j = (*j).max(*k),
                None => den.push((f.clone(), *k)),
            }
        }
        // Each numerator times the factors its denominator lacks.
        let widen = |r: &Rational| -> Option<Poly> {
            let mut n = r.num.clone();
            for (f, k) in &den {
                let have = r.den.iter().find(|(g, _)| g == f).map_or(0, |(_, j)| *j);
                n = mul(&n, &power(f, k - have)?);
                if too_large(&n) {
                    return None;
                }
            }
            Some(n)
        };
        let mut num = widen(self)?;
        add_into(&mut num, &widen(other)?, 1.0);
        let scale = self
            .num
            .iter()
            .chain(other.num.iter())
            .map(|(_, c)| c.abs())
            .fold(0.0, f64::max);
        chop(&mut num, scale);
        let mut out = Rational { num, den };
        out.cancel();
        Some(out)
    }

    /// `1 / self`, `None` for zero or a numerator too large to be a factor.
    fn reciprocal(&self) -> Option<Rational> {
        if self.num.is_empty() {
            return None;
        }
        let mut num = constant(1.0);
        for (f, k) in &self.den {
            num = mul(&num, &power(f, *k)?);
        }
        let (m, lead, f) = normalise(&self.num);
        num = times_monomial(&num, &inverse(&m), 1.0 / lead);
        let den = if f.len() > 1 {
            vec![(f, 1)]
        } else {
            Vec::new()
        };
        Some(Rational { num, den })
    }

    fn expr(&self, pool: &mut Pool) -> ExprId {
        let num = rebuild(pool, &self.num);
        let mut den: Option<ExprId> = None;
        for (f, k) in &self.den {
            let base = rebuild(pool, f);
            let exp = pool.num(f64::from(*k));
            let factor = pool.pow(base, exp);
            den = Some(match den {
                Some(d) => pool.mul(d, factor),
                None => factor,
            });
        }
        match den {
            Some(d) => pool.div(num, d),
            None => num,
        }
    }
}

/// Builds rational forms, memoising the atoms that are sums.
struct Builder<'s> {
    simplifier: &'s mut Simplifier,
    sums: FastMap<ExprId, Option<Rational>>,
}

impl Builder<'_> {
    /// The rational form of an expression, from its canonical polynomial.
    fn of(&mut self, pool: &mut Pool, id: ExprId) -> Option<Rational> {
        let poly = self.simplifier.poly(pool, id);
        let mut total = Rational::of(Poly::default());
        for (m, c) in poly.iter() {
            let mut term = Rational::of(constant(*c));
            for &(a, e) in m.iter() {
                let base = self.atom(pool, a)?;
                let base = if e < 0 { base.reciprocal()? } else { base };
                for _ in 0..e.unsigned_abs() {
                    term = term.times(&base)?;
                }
            }
            total = total.plus(&term)?;
        }
        Some(total)
    }

    /// An atom: a sum (the denominator of some term) is opened, anything else stays whole.
    fn atom(&mut self, pool: &mut Pool, a: ExprId) -> Option<Rational> {
        if !matches!(pool.node(a), Node::Binary(BinOp::Add | BinOp::Sub, ..)) {
            let mut m = Monomial::new();
            m.push((a, 1));
            return Some(Rational::of(Poly::single(m, 1.0)));
        }
        if let Some(r) = self.sums.get(&a) {
            return r.clone();
        }
        let r = self.of(pool, a);
        self.sums.insert(a, r.clone());
        r
    }
}

impl Simplifier {
    /// `root` as one numerator over a product of sums in lowest terms (see the module
    /// documentation), or `None` when a polynomial would pass [`MAX_TERMS`].
    /// `None` too when there is no sum to open: the canonical form is then the same.
    pub(crate) fn rational(&mut self, pool: &mut Pool, root: ExprId) -> Option<ExprId> {
        let poly = self.poly(pool, root);
        let is_sum = |a: ExprId| matches!(pool.node(a), Node::Binary(BinOp::Add | BinOp::Sub, ..));
        if !poly.iter().any(|(m, _)| m.iter().any(|&(a, _)| is_sum(a))) {
            return None;
        }
        let mut builder = Builder {
            simplifier: self,
            sums: FastMap::default(),
        };
        let r = builder.of(pool, root)?;
        Some(r.expr(pool))
    }
}

impl Simplifier {
    /// `root` (canonical) divided by the factors its terms share that hold parameters only
    /// and are sums: grouping the terms by what they hold besides parameters, the first
    /// group's coefficient is tried as a divisor of the whole, while it divides exactly.
    /// A relation `root = 0` keeps its zeros; a single-term factor (a scale in the model's
    /// units) is left as it is.
    pub(crate) fn without_content(&mut self, pool: &mut Pool, root: ExprId) -> ExprId {
        let mut poly = Poly::clone(&self.poly(pool, root));
        let mut changed = false;
        for _ in 0..4 {
            let Some((first, _)) = poly.iter().next() else {
                break;
            };
            let rest_of = |m: &Monomial| -> Monomial {
                m.iter()
                    .filter(|&&(a, _)| !pool.is_constant(a))
                    .copied()
                    .collect()
            };
            let key = rest_of(first);
            let coefficient = Poly::from_terms(
                poly.iter()
                    .filter(|(m, _)| rest_of(m) == key)
                    .map(|(m, c)| {
                        (
                            m.iter()
                                .filter(|&&(a, _)| pool.is_constant(a))
                                .copied()
                                .collect(),
                            *c,
                        )
                    })
                    .collect(),
            );
            let (_, _, factor) = normalise(&coefficient);
            if factor.len() < 2 {
                break;
            }
            match exact_quotient(&poly, &factor) {
                Some(q) => {
                    poly = q;
                    changed = true;
                }
                None => break,
            }
        }
        if changed {
            rebuild(pool, &poly)
        } else {
            root
        }
    }
}

impl Simplifier {
    /// `root` (canonical) divided by the monomial of parameters all its terms share and by
    /// its first term's number: for a relation `root = 0` whose scale is arbitrary (a
    /// combination of two ARRs), the scale that says least.
    pub(crate) fn without_scale(&mut self, pool: &mut Pool, root: ExprId) -> ExprId {
        let poly = Poly::clone(&self.poly(pool, root));
        // Only atoms present in every term, by their smallest power: dividing never brings
        // in an atom that some term does not hold (v2/RL stays v2/RL next to I0).
        let mut scale: Vec<(ExprId, i32)> = poly
            .iter()
            .next()
            .map(|(m, _)| {
                m.iter()
                    .filter(|&&(a, _)| pool.is_constant(a))
                    .copied()
                    .collect()
            })
            .unwrap_or_default();
        for (m, _) in poly.iter() {
            scale.retain_mut(|(a, e)| match m.iter().find(|(b, _)| b == a) {
                Some(&(_, f)) if f.signum() == e.signum() => {
                    *e = if e.abs() <= f.abs() { *e } else { f };
                    true
                }
                _ => false,
            });
        }
        let scale: Monomial = scale.into_iter().collect();
        let lead = poly.iter().next().map_or(1.0, |(_, c)| *c);
        if scale.is_empty() && lead == 1.0 {
            return root;
        }
        rebuild(pool, &times_monomial(&poly, &inverse(&scale), 1.0 / lead))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::ParamId;
    use crate::symbolic::{Leaf, Printer};

    fn text(pool: &Pool, e: ExprId) -> String {
        Printer::new(pool, |l: Leaf| match l {
            Leaf::Param(ParamId(i)) => ["a", "b", "c", "d"][i as usize].to_string(),
            other => format!("{other:?}"),
        })
        .text(e)
    }

    /// A nested fraction whose inner sum cancels: 1/(1/a + 1/b) * (a + b) / a is b; and a
    /// resistance pair: 1/(1/a + 1/b) is a b/(a + b), one fraction.
    #[test]
    fn nested_fractions_are_put_in_lowest_terms() {
        let mut pool = Pool::default();
        let [a, b] = [0, 1].map(|i| pool.leaf(Leaf::Param(ParamId(i))));
        let one = pool.num(1.0);
        let (ia, ib) = (pool.div(one, a), pool.div(one, b));
        let g = pool.add(ia, ib);
        let r = pool.div(one, g);
        let mut s = Simplifier::default();
        let parallel = s.rational(&mut pool, r).expect("small");
        assert_eq!(text(&pool, parallel), "a * b / (a + b)");
        let sum = pool.add(a, b);
        let scaled = pool.mul(r, sum);
        let e = pool.div(scaled, a);
        let cancelled = s.rational(&mut pool, e).expect("small");
        assert_eq!(text(&pool, cancelled), "b");
    }

    /// (a^2 - b^2)/(a + b) is a - b, and (a c + b c)/((a + b) d) is c/d: division is exact
    /// in several variables; a numerator the sum does not divide keeps its denominator.
    #[test]
    fn a_factor_of_the_numerator_cancels() {
        let mut pool = Pool::default();
        let [a, b, c, d] = [0, 1, 2, 3].map(|i| pool.leaf(Leaf::Param(ParamId(i))));
        let two = pool.num(2.0);
        let (a2, b2) = (pool.pow(a, two), pool.pow(b, two));
        let diff = pool.sub(a2, b2);
        let sum = pool.add(a, b);
        let q = pool.div(diff, sum);
        let mut s = Simplifier::default();
        let out = s.rational(&mut pool, q).expect("small");
        assert_eq!(text(&pool, out), "a - b");
        let (ac, bc) = (pool.mul(a, c), pool.mul(b, c));
        let num = pool.add(ac, bc);
        let den = pool.mul(sum, d);
        let q = pool.div(num, den);
        let out = s.rational(&mut pool, q).expect("small");
        assert_eq!(text(&pool, out), "c / d");
        let q = pool.div(c, sum);
        let out = s.rational(&mut pool, q).expect("small");
        assert_eq!(text(&pool, out), "c / (a + b)");
    }
}
