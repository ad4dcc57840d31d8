//! Simplification to a canonical sum of products, which collects like terms.
//!
//! An expression is expanded into a polynomial whose variables are *atoms*: leaves, function
//! calls and integrals (with their arguments simplified first), and reciprocals of sums.
//! Like terms are collected, zero terms dropped, and the result rebuilt in a canonical order:
//! two expressions equal as polynomials in their atoms print identically, and a term that
//! cancels (the backlash torque in the bench's first ARR) disappears. Expansion is bounded
//! ([`MAX_TERMS`]): a product that would grow past it is kept as an atom, so simplification
//! always terminates in time linear in the result.

use std::collections::{BTreeMap, HashMap};

use super::pool::{ExprId, Leaf, Node, Pool};
use crate::expr::BinOp;

/// The most terms a product may expand to before it is kept whole.
pub const MAX_TERMS: usize = 256;

/// Atoms with their (non-zero) integer exponents.
type Monomial = BTreeMap<ExprId, i32>;
/// Monomials with their (non-zero) coefficients.
type Poly = BTreeMap<Monomial, f64>;

/// Simplifies expressions of one pool, memoising what it has seen.
#[derive(Default)]
pub struct Simplifier {
    memo: HashMap<ExprId, ExprId>,
    polys: HashMap<ExprId, Poly>,
}

fn constant(c: f64) -> Poly {
    let mut p = Poly::new();
    if c != 0.0 {
        p.insert(Monomial::new(), c);
    }
    p
}

fn constant_poly(m: Monomial, c: f64) -> Poly {
    let mut p = Poly::new();
    if c != 0.0 {
        p.insert(m, c);
    }
    p
}

fn atom(id: ExprId) -> Poly {
    let mut m = Monomial::new();
    m.insert(id, 1);
    let mut p = Poly::new();
    p.insert(m, 1.0);
    p
}

fn add_into(acc: &mut Poly, other: &Poly, scale: f64) {
    for (m, c) in other {
        let entry = acc.entry(m.clone()).or_insert(0.0);
        *entry += scale * c;
        if *entry == 0.0 {
            acc.remove(m);
        }
    }
}

fn mul_monomials(a: &Monomial, b: &Monomial) -> Monomial {
    let mut out = a.clone();
    for (atom, e) in b {
        let entry = out.entry(*atom).or_insert(0);
        *entry += e;
        if *entry == 0 {
            out.remove(atom);
        }
    }
    out
}

fn mul(a: &Poly, b: &Poly) -> Poly {
    let mut out = Poly::new();
    for (ma, ca) in a {
        for (mb, cb) in b {
            let m = mul_monomials(ma, mb);
            let entry = out.entry(m.clone()).or_insert(0.0);
            *entry += ca * cb;
            if *entry == 0.0 {
                out.remove(&m);
            }
        }
    }
    out
}

impl Simplifier {
    /// The simplified form of `root`.
    pub fn simplify(&mut self, pool: &mut Pool, root: ExprId) -> ExprId {
        if let Some(&done) = self.memo.get(&root) {
            return done;
        }
        let poly = self.poly(pool, root);
        let out = rebuild(pool, &poly);
        self.memo.insert(root, out);
        out
    }

    fn poly(&mut self, pool: &mut Pool, id: ExprId) -> Poly {
        // Shared subexpressions are expanded once.
        if let Some(p) = self.polys.get(&id) {
            return p.clone();
        }
        let p = self.poly_uncached(pool, id);
        self.polys.insert(id, p.clone());
        p
    }

    fn poly_uncached(&mut self, pool: &mut Pool, id: ExprId) -> Poly {
        match pool.node(id) {
            Node::Num(bits) => constant(f64::from_bits(bits)),
            Node::Leaf(_) => atom(id),
            Node::Neg(a) => {
                let mut p = self.poly(pool, a);
                p.values_mut().for_each(|c| *c = -*c);
                p
            }
            Node::Binary(op, a, b) => self.binary(pool, op, a, b, id),
            Node::Call1(f, a) => {
                let a = self.simplify(pool, a);
                atom(pool.call(f, &[a]))
            }
            Node::Call2(f, a, b) => {
                let (a, b) = (self.simplify(pool, a), self.simplify(pool, b));
                atom(pool.call(f, &[a, b]))
            }
            Node::Int(a) => self.integral(pool, a),
        }
    }

    /// int(Σ c·P·R) = Σ c·P·int(R), P the parameters (constant in time) of a term, so that
    /// int(y1 - N·y2) and int(y1) - N·int(y2) are one and the same.
    fn integral(&mut self, pool: &mut Pool, a: ExprId) -> Poly {
        let inner = self.poly(pool, a);
        let mut out = Poly::new();
        for (m, c) in &inner {
            let (constant, varying): (Monomial, Monomial) = m
                .iter()
                .map(|(k, e)| (*k, *e))
                .partition(|(k, _)| matches!(pool.node(*k), Node::Leaf(Leaf::Param(_))));
            let varying_expr = if varying.is_empty() {
                pool.leaf(Leaf::Time)
            } else {
                let mut single = Poly::new();
                single.insert(varying, 1.0);
                let body = rebuild(pool, &single);
                pool.int(body)
            };
            let term = mul(&constant_poly(constant, *c), &atom(varying_expr));
            add_into(&mut out, &term, 1.0);
        }
        out
    }

    fn binary(&mut self, pool: &mut Pool, op: BinOp, a: ExprId, b: ExprId, whole: ExprId) -> Poly {
        match op {
            BinOp::Add | BinOp::Sub => {
                let mut p = self.poly(pool, a);
                let q = self.poly(pool, b);
                add_into(&mut p, &q, if op == BinOp::Add { 1.0 } else { -1.0 });
                p
            }
            BinOp::Mul => {
                let (p, q) = (self.poly(pool, a), self.poly(pool, b));
                if p.len() * q.len() > MAX_TERMS {
                    return self.opaque(pool, whole);
                }
                mul(&p, &q)
            }
            BinOp::Div => {
                let p = self.poly(pool, a);
                let q = self.poly(pool, b);
                let inverse = reciprocal(pool, &q);
                match inverse {
                    Some(inv) => mul(&p, &inv),
                    None => p, // division by zero: keep the numerator, flagged by NaN below
                }
            }
            BinOp::Pow => {
                let base = self.poly(pool, a);
                let exponent = pool
                    .as_num(b)
                    .filter(|e| e.fract() == 0.0 && e.abs() <= 8.0);
                match exponent {
                    // A power of a sum stays a power (1/(1 + x)^2 reads better expanded
                    // nowhere); a power of a monomial multiplies its exponents.
                    Some(e) if base.len() > 1 => {
                        let (lead, sum) = normalised_sum(pool, &base);
                        let n = e as i32;
                        let mut m = Monomial::new();
                        m.insert(sum, n);
                        let mut p = Poly::new();
                        p.insert(m, lead.powi(n));
                        p
                    }
                    Some(e) => {
                        let n = e as i32;
                        let mut out = constant(1.0);
                        let factor = if n >= 0 {
                            Some(base)
                        } else {
                            reciprocal(pool, &base)
                        };
                        let Some(factor) = factor else {
                            return constant(f64::NAN);
                        };
                        for _ in 0..n.unsigned_abs() {
                            out = mul(&out, &factor);
                        }
                        out
                    }
                    None => {
                        let (a, b) = (rebuild(pool, &base), self.simplify(pool, b));
                        atom(pool.pow(a, b))
                    }
                }
            }
        }
    }

    /// A node kept whole (too large to expand), with its operands simplified.
    fn opaque(&mut self, pool: &mut Pool, id: ExprId) -> Poly {
        let Node::Binary(op, a, b) = pool.node(id) else {
            return atom(id);
        };
        let (a, b) = (self.simplify(pool, a), self.simplify(pool, b));
        atom(pool.binary(op, a, b))
    }
}

/// 1/q as a polynomial: exact for a single monomial, otherwise an atom `1 / q`.
fn reciprocal(pool: &mut Pool, q: &Poly) -> Option<Poly> {
    match q.len() {
        0 => None,
        1 => {
            let (m, c) = q.iter().next()?;
            let inv: Monomial = m.iter().map(|(a, e)| (*a, -e)).collect();
            let mut p = Poly::new();
            p.insert(inv, 1.0 / c);
            Some(p)
        }
        _ => {
            let (lead, sum) = normalised_sum(pool, q);
            let mut m = Monomial::new();
            m.insert(sum, -1);
            let mut p = Poly::new();
            p.insert(m, 1.0 / lead);
            Some(p)
        }
    }
}

/// A sum as `lead · S` with S's leading coefficient 1, so 2a + 2b and a + b share the atom S.
fn normalised_sum(pool: &mut Pool, q: &Poly) -> (f64, ExprId) {
    let lead = q.values().next().copied().unwrap_or(1.0);
    let mut scaled = q.clone();
    scaled.values_mut().for_each(|c| *c /= lead);
    (lead, rebuild(pool, &scaled))
}

/// The polynomial as an expression: terms in canonical order, negative powers as a quotient.
fn rebuild(pool: &mut Pool, poly: &Poly) -> ExprId {
    let mut terms: Vec<(bool, ExprId)> = Vec::with_capacity(poly.len());
    // Constant last, as people write it.
    let mut ordered: Vec<(&Monomial, &f64)> = poly.iter().filter(|(m, _)| !m.is_empty()).collect();
    ordered.extend(poly.iter().filter(|(m, _)| m.is_empty()));
    for (m, &c) in ordered {
        // The coefficient first, then the atoms: 4 * K * j0, not 4 * (K * j0).
        let magnitude = pool.num(c.abs());
        let mut numerator: Option<ExprId> = (c.abs() != 1.0).then_some(magnitude);
        let mut denominator: Option<ExprId> = None;
        for (&a, &e) in m {
            let exp = pool.num(f64::from(e.abs()));
            let factor = pool.pow(a, exp);
            let slot = if e > 0 {
                &mut numerator
            } else {
                &mut denominator
            };
            *slot = Some(match *slot {
                Some(x) => pool.mul(x, factor),
                None => factor,
            });
        }
        let body = numerator.unwrap_or(magnitude);
        let term = match denominator {
            Some(d) => pool.div(body, d),
            None => body,
        };
        terms.push((c > 0.0 || c.is_nan(), term));
    }
    pool.signed_sum(&terms)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::ParamId;

    #[test]
    fn like_terms_cancel_and_equal_polynomials_print_alike() {
        let mut p = Pool::default();
        let (w, n, x) = (
            p.leaf(Leaf::Param(ParamId(0))),
            p.leaf(Leaf::Param(ParamId(1))),
            p.leaf(Leaf::Time),
        );
        // w + (1/n)·(x − n·w)  ==  x / n
        let nw = p.mul(n, w);
        let inner = p.sub(x, nw);
        let one = p.num(1.0);
        let inv = p.div(one, n);
        let scaled = p.mul(inv, inner);
        let e = p.add(w, scaled);
        let mut s = Simplifier::default();
        let simple = s.simplify(&mut p, e);
        let expected = p.div(x, n);
        let expected = s.simplify(&mut p, expected);
        assert_eq!(simple, expected);
        assert!(!p.leaves(simple).contains(&Leaf::Param(ParamId(0))));
    }

    #[test]
    fn integrals_are_linear() {
        let mut p = Pool::default();
        let n = p.leaf(Leaf::Param(ParamId(0)));
        let (y1, y2) = (
            p.leaf(Leaf::Input(crate::graph::InputId(0), 0)),
            p.leaf(Leaf::Input(crate::graph::InputId(1), 0)),
        );
        let ny2 = p.mul(n, y2);
        let d = p.sub(y1, ny2);
        let whole = p.int(d);
        let (i1, i2) = (p.int(y1), p.int(y2));
        let ni2 = p.mul(n, i2);
        let parts = p.sub(i1, ni2);
        let mut s = Simplifier::default();
        assert_eq!(s.simplify(&mut p, whole), s.simplify(&mut p, parts));
    }

    #[test]
    fn expansion_is_bounded() {
        let mut p = Pool::default();
        let mut e = p.leaf(Leaf::Time);
        for k in 0..12 {
            let c = p.leaf(Leaf::Param(ParamId(k)));
            let sum = p.add(e, c);
            e = p.mul(sum, sum);
        }
        let mut s = Simplifier::default();
        let simple = s.simplify(&mut p, e);
        assert!(p.len() < 100_000, "expansion ran away: {} nodes", p.len());
        let _ = simple;
    }
}
