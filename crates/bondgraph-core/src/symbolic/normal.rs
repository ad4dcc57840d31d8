//! Simplification to a canonical sum of products, which collects like terms.
//!
//! An expression is expanded into a polynomial whose variables are *atoms*: leaves, function
//! calls and integrals (with their arguments simplified first), and reciprocals of sums.
//! Like terms are collected, zero terms dropped, and the result rebuilt in a canonical order:
//! two expressions equal as polynomials in their atoms print identically, and a term that
//! cancels (the backlash torque in the bench's first ARR) disappears. Expansion is bounded
//! ([`MAX_TERMS`]): a product that would grow past it is kept as an atom, so simplification
//! always terminates in time linear in the result.

use std::collections::BTreeMap;
use std::rc::Rc;

use super::hash::{FastMap, FastSet};

use super::monomial::Monomial;
use super::pool::{children, ExprId, Leaf, Node, Pool};
use crate::expr::BinOp;

/// The most terms a product may expand to before it is kept whole.
pub(super) const MAX_TERMS: usize = 256;

/// Monomials with their (non-zero) coefficients, sorted by monomial, each monomial once.
///
/// A sorted vector rather than a map: a polynomial is built whole (sort, then combine) or
/// merged with another, never edited term by term, and the cache holds hundreds of
/// thousands of them, which a vector stores in one allocation.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Poly(pub(super) Vec<(Monomial, f64)>);

impl Poly {
    /// The sum of `terms`, in any order: like monomials are added in the order given (so
    /// the result does not depend on how they were sorted), and zero sums dropped.
    pub(super) fn from_terms(mut terms: Vec<(Monomial, f64)>) -> Poly {
        terms.sort_by(|a, b| a.0.cmp(&b.0)); // stable: like terms keep their order
        let mut out: Vec<(Monomial, f64)> = Vec::with_capacity(terms.len());
        for (m, c) in terms {
            match out.last_mut() {
                Some(last) if last.0 == m => last.1 += c,
                _ => {
                    if out.last().is_some_and(|l| l.1 == 0.0) {
                        out.pop();
                    }
                    out.push((m, c));
                }
            }
        }
        if out.last().is_some_and(|l| l.1 == 0.0) {
            out.pop();
        }
        Poly(out)
    }

    /// `c·m`, or zero.
    pub(super) fn single(m: Monomial, c: f64) -> Poly {
        Poly(if c != 0.0 { vec![(m, c)] } else { Vec::new() })
    }

    pub(super) fn len(&self) -> usize {
        self.0.len()
    }

    pub(super) fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = (&Monomial, &f64)> {
        self.0.iter().map(|(m, c)| (m, c))
    }

    pub(super) fn scale(&mut self, factor: f64) {
        self.0.iter_mut().for_each(|(_, c)| *c *= factor);
    }
}

/// Simplifies expressions of one pool, memoising what it has seen.
#[derive(Default)]
pub(crate) struct Simplifier {
    memo: FastMap<ExprId, ExprId>,
    /// Shared, so that reading a cached polynomial does not copy it.
    polys: FastMap<ExprId, Rc<Poly>>,
}

pub(super) fn constant(c: f64) -> Poly {
    Poly::single(Monomial::new(), c)
}

fn constant_poly(m: Monomial, c: f64) -> Poly {
    Poly::single(m, c)
}

fn atom(id: ExprId) -> Poly {
    Poly::single([(id, 1)].into_iter().collect(), 1.0)
}

/// `acc += scale·other`, merging the two sorted term lists.
pub(super) fn add_into(acc: &mut Poly, other: &Poly, scale: f64) {
    let mine = std::mem::take(&mut acc.0);
    let mut out = Vec::with_capacity(mine.len() + other.len());
    let mut theirs = other.0.iter().peekable();
    for (m, c) in mine {
        while let Some((n, d)) = theirs.next_if(|(n, _)| *n < m) {
            push_nonzero(&mut out, n.clone(), scale * d);
        }
        match theirs.next_if(|(n, _)| *n == m) {
            Some((_, d)) => push_nonzero(&mut out, m, c + scale * d),
            None => out.push((m, c)),
        }
    }
    for (n, d) in theirs {
        push_nonzero(&mut out, n.clone(), scale * d);
    }
    acc.0 = out;
}

fn push_nonzero(out: &mut Vec<(Monomial, f64)>, m: Monomial, c: f64) {
    if c != 0.0 {
        out.push((m, c));
    }
}

pub(super) fn mul_monomials(a: &Monomial, b: &Monomial) -> Monomial {
    let mut out = Monomial::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let ((x, ex), (y, ey)) = (a[i], b[j]);
        match x.cmp(&y) {
            std::cmp::Ordering::Less => {
                out.push((x, ex));
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push((y, ey));
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                if ex + ey != 0 {
                    out.push((x, ex + ey));
                }
                i += 1;
                j += 1;
            }
        }
    }
    out.extend(a[i..].iter().copied());
    out.extend(b[j..].iter().copied());
    out
}

pub(super) fn mul(a: &Poly, b: &Poly) -> Poly {
    let mut terms = Vec::with_capacity(a.len() * b.len());
    for (ma, ca) in a.iter() {
        for (mb, cb) in b.iter() {
            terms.push((mul_monomials(ma, mb), ca * cb));
        }
    }
    Poly::from_terms(terms)
}

/// An expression in canonical form, as a polynomial in atoms, for algebra that should not
/// leave it (the elimination of torn unknowns adds, multiplies and differentiates these).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Polynomial(Poly);

impl Polynomial {
    /// The expression, in canonical order.
    pub(crate) fn expr(&self, pool: &mut Pool) -> ExprId {
        rebuild(pool, &self.0)
    }

    /// `self + scale·other`.
    pub(crate) fn plus(&self, other: &Polynomial, scale: f64) -> Polynomial {
        let mut out = self.clone();
        out.add_scaled(other, scale);
        out
    }

    /// `self += scale·other`.
    pub(crate) fn add_scaled(&mut self, other: &Polynomial, scale: f64) {
        add_into(&mut self.0, &other.0, scale);
    }

    /// `self · other`, fully expanded.
    pub(crate) fn times(&self, other: &Polynomial) -> Polynomial {
        Polynomial(mul(&self.0, &other.0))
    }

    /// Whether it is zero.
    pub(crate) fn is_zero(&self) -> bool {
        self.0.is_empty()
    }

    /// How many terms it has.
    pub(crate) fn terms(&self) -> usize {
        self.0.len()
    }

    /// Without the terms whose coefficient is below `relative` times the largest one: what
    /// rounding leaves of a cancellation that is exact in real arithmetic.
    pub(crate) fn chop(&mut self, relative: f64) {
        let largest = self.0.iter().map(|(_, c)| c.abs()).fold(0.0, f64::max);
        self.0 .0.retain(|(_, c)| c.abs() > relative * largest);
    }

    /// Its single term as `c·m`, if it has one.
    fn monomial(&self) -> Option<(&Monomial, f64)> {
        match self.0 .0.as_slice() {
            [(m, c)] => Some((m, *c)),
            _ => None,
        }
    }

    /// `self / other` when `other` is a single term (so the quotient is exact).
    pub(crate) fn over_monomial(&self, other: &Polynomial) -> Option<Polynomial> {
        let (m, c) = other.monomial()?;
        let inverse: Monomial = m.iter().map(|&(a, e)| (a, -e)).collect();
        Some(self.times(&Polynomial(Poly::single(inverse, 1.0 / c))))
    }

    /// Every atom it holds.
    pub(crate) fn atoms(&self) -> impl Iterator<Item = ExprId> + '_ {
        self.0.iter().flat_map(|(m, _)| m.iter().map(|&(a, _)| a))
    }

    /// `(with, without)`: the terms whose atoms all pass `keep`, and the others.
    pub(crate) fn partition(
        &self,
        mut keep: impl FnMut(ExprId) -> bool,
    ) -> (Polynomial, Polynomial) {
        let (mut with, mut without) = (Vec::new(), Vec::new());
        for (m, &c) in self.0.iter() {
            let side = if m.iter().all(|&(a, _)| keep(a)) {
                &mut with
            } else {
                &mut without
            };
            side.push((m.clone(), c));
        }
        // Each half of a sorted list of distinct monomials is one too.
        (Polynomial(Poly(with)), Polynomial(Poly(without)))
    }

    /// The polynomial read as `Σₖ cₖ·xₖ + rest`, where `var` tells which leaf atoms are the
    /// `xₖ` (and gives k): `c₀..c_top` and `rest`, or `None` if some `xₖ` enters otherwise than
    /// linearly (a power, a product of two, or inside another atom) or none occurs.
    pub(crate) fn split_linear(
        &self,
        pool: &Pool,
        var: impl Fn(Leaf) -> Option<u32>,
    ) -> Option<(Vec<Polynomial>, Polynomial)> {
        let mut parts: BTreeMap<Option<u32>, Vec<(Monomial, f64)>> = BTreeMap::new();
        let mut inside: FastMap<ExprId, bool> = FastMap::default();
        for (m, c) in self.0.iter() {
            let mut order = None;
            let mut rest = Monomial::with_capacity(m.len());
            for &(a, e) in m.iter() {
                let k = match pool.node(a) {
                    Node::Leaf(l) => var(l),
                    _ => {
                        let holds = *inside.entry(a).or_insert_with(|| {
                            pool.leaves(a).into_iter().any(|l| var(l).is_some())
                        });
                        if holds {
                            return None;
                        }
                        None
                    }
                };
                match k {
                    Some(_) if e != 1 || order.is_some() => return None,
                    Some(k) => order = Some(k),
                    None => rest.push((a, e)),
                }
            }
            parts.entry(order).or_default().push((rest, *c));
        }
        let top = parts.keys().filter_map(|k| *k).max()?;
        // Taking x_k out of sorted monomials can reorder them: sort again.
        let mut part = |k| Polynomial(Poly::from_terms(parts.remove(&k).unwrap_or_default()));
        let coefficients = (0..=top).map(|k| part(Some(k))).collect();
        let rest = part(None);
        Some((coefficients, rest))
    }
}

impl Simplifier {
    /// The simplified form of `root`.
    pub(crate) fn simplify(&mut self, pool: &mut Pool, root: ExprId) -> ExprId {
        if let Some(&done) = self.memo.get(&root) {
            return done;
        }
        let poly = self.poly(pool, root);
        let out = rebuild(pool, &poly);
        self.memo.insert(root, out);
        out
    }

    /// `root` in canonical form, with the terms that share reciprocals of sums put over
    /// their common denominator when that leaves fewer terms:
    /// `g E/(E+1)^2 + g E/(E+1) - g E^2/(E+1)^2` is `2 g E/(E+1)^2`. The numerator is
    /// expanded within [`MAX_TERMS`]; past it the canonical form is kept.
    pub(crate) fn together(&mut self, pool: &mut Pool, root: ExprId) -> ExprId {
        // Most expressions hold no reciprocal of a sum: nothing to expand.
        let mut reciprocal = false;
        pool.visit_reachable(&[root], |_, node| {
            reciprocal |= matches!(node, Node::Binary(BinOp::Div | BinOp::Pow, ..));
        });
        if !reciprocal {
            return root;
        }
        let poly = self.poly(pool, root);
        let mut depth: BTreeMap<ExprId, i32> = BTreeMap::new();
        for (m, _) in poly.iter() {
            for &(a, e) in m.iter() {
                if e < 0 && self.poly(pool, a).len() > 1 {
                    let k = depth.entry(a).or_insert(0);
                    *k = (*k).max(-e);
                }
            }
        }
        if depth.is_empty() {
            return self.simplify(pool, root);
        }
        // Only the terms over a sum are put together; the others stay as they are.
        let over_sum = |m: &Monomial| m.iter().any(|(a, e)| *e < 0 && depth.contains_key(a));
        let (fractions, plain): (Vec<_>, Vec<_>) = poly.iter().partition(|(m, _)| over_sum(m));
        let mut numerator = Poly::default();
        for (m, &c) in &fractions {
            // The term times every denominator S^k: S^(k + e) for the sums it holds with
            // exponent e, S^k for those it does not hold.
            let rest: Monomial = m
                .iter()
                .filter(|(a, _)| !depth.contains_key(a))
                .copied()
                .collect();
            let mut term = constant(c);
            for (&a, &k) in &depth {
                let e = m.iter().find(|(b, _)| *b == a).map_or(0, |(_, e)| *e);
                let sum = self.poly(pool, a);
                for _ in 0..(k + e) {
                    term = mul(&term, &sum);
                    if term.len() > MAX_TERMS {
                        return self.simplify(pool, root);
                    }
                }
            }
            add_into(&mut numerator, &mul(&term, &constant_poly(rest, 1.0)), 1.0);
            if numerator.len() > MAX_TERMS {
                return self.simplify(pool, root);
            }
        }
        if numerator.len() >= fractions.len() {
            return self.simplify(pool, root);
        }
        let denominator: Monomial = depth.iter().map(|(&a, &k)| (a, -k)).collect();
        let mut together = mul(&numerator, &constant_poly(denominator, 1.0));
        let plain = Poly::from_terms(plain.into_iter().map(|(m, c)| (m.clone(), *c)).collect());
        add_into(&mut together, &plain, 1.0);
        rebuild(pool, &together)
    }

    /// Forgets the polynomials of the nodes seen so far (not the simplified forms).
    pub(crate) fn forget_polynomials(&mut self) {
        self.polys = FastMap::default();
    }

    /// The canonical form of `root` as a polynomial.
    pub(crate) fn polynomial(&mut self, pool: &mut Pool, root: ExprId) -> Polynomial {
        Polynomial(Poly::clone(&self.poly(pool, root)))
    }

    /// d/dt of a polynomial, term by term: an atom's derivative comes from `rule` when it
    /// is a leaf (a measured signal's is its next derivative, a single atom), from
    /// `derivatives` otherwise; `None` if some atom has none.
    pub(crate) fn derivative<F: FnMut(&mut Pool, Leaf) -> Option<ExprId>>(
        &mut self,
        pool: &mut Pool,
        p: &Polynomial,
        derivatives: &mut super::Derivatives<Leaf, F>,
    ) -> Option<Polynomial> {
        type Atom = (Rc<Poly>, Rc<[ExprId]>);
        let mut of_atom: FastMap<ExprId, Atom> = FastMap::default();
        let mut out = Vec::new();
        for (m, &c) in p.0.iter() {
            for (i, &(a, e)) in m.iter().enumerate() {
                let (da, jumps) = match of_atom.get(&a) {
                    Some((da, jumps)) => (Rc::clone(da), Rc::clone(jumps)),
                    None => {
                        let (d, jumps) = match pool.node(a) {
                            Node::Leaf(l) => (derivatives.of_leaf(pool, l)?, Vec::new()),
                            _ => derivatives.with_jumps(pool, a)?,
                        };
                        let da = self.poly(pool, d);
                        let jumps: Rc<[ExprId]> = jumps.into();
                        of_atom.insert(a, (Rc::clone(&da), Rc::clone(&jumps)));
                        (da, jumps)
                    }
                };
                if da.is_empty() && jumps.is_empty() {
                    continue;
                }
                // c·e·a^(e−1)·(the other atoms)·da
                let mut rest = m.clone();
                if e == 1 {
                    rest.remove(i);
                } else {
                    rest[i].1 = e - 1;
                }
                // The impulse of a jump times the other factors: none where one vanishes.
                let held =
                    |x: ExprId| (rest.iter()).any(|&(b, _)| super::derive::vanishes(pool, b, x));
                if !jumps.iter().all(|&x| held(x)) {
                    derivatives.refuse();
                    return None;
                }
                if da.is_empty() {
                    continue;
                }
                let mut terms = da.iter();
                if let (Some((dm, dc)), None) = (terms.next(), terms.next()) {
                    // A measured signal's derivative is one atom: no product to expand.
                    let m = if rest.is_empty() {
                        dm.clone()
                    } else {
                        mul_monomials(&rest, dm)
                    };
                    out.push((m, c * f64::from(e) * dc));
                    continue;
                }
                for (dm, dc) in da.iter() {
                    out.push((mul_monomials(&rest, dm), c * f64::from(e) * dc));
                }
            }
        }
        Some(Polynomial(Poly::from_terms(out)))
    }

    pub(super) fn poly(&mut self, pool: &mut Pool, id: ExprId) -> Rc<Poly> {
        // Shared subexpressions are expanded once.
        if let Some(p) = self.polys.get(&id) {
            return Rc::clone(p);
        }
        // Children before parents, so that each node finds what it needs cached: a product
        // of ten thousand factors is expanded in a loop, not in ten thousand nested calls.
        let ready = children(pool.node(id)).all(|c| self.polys.contains_key(&c));
        if !ready {
            for x in self.needed_below(pool, id) {
                let p = Rc::new(self.poly_uncached(pool, x));
                self.polys.insert(x, p);
            }
        }
        let p = Rc::new(self.poly_uncached(pool, id));
        self.polys.insert(id, Rc::clone(&p));
        p
    }

    /// The uncached nodes below `id` whose polynomials it needs, children first. The inner
    /// links of a chain of `+` and `-` are left out: [`Simplifier::sum`] walks through them.
    fn needed_below(&self, pool: &Pool, id: ExprId) -> Vec<ExprId> {
        let is_sum = |x: ExprId| matches!(pool.node(x), Node::Binary(BinOp::Add | BinOp::Sub, ..));
        let mut out = Vec::new();
        let mut seen: FastSet<ExprId> = FastSet::default();
        let mut stack = vec![(id, true)];
        while let Some((x, link)) = stack.pop() {
            if !seen.insert(x) {
                continue;
            }
            if !link {
                out.push(x);
            }
            let node = pool.node(x);
            let left = match node {
                Node::Binary(BinOp::Add | BinOp::Sub, a, _) => Some(a),
                _ => None,
            };
            for c in children(node).filter(|c| !self.polys.contains_key(c)) {
                stack.push((c, left == Some(c) && is_sum(c)));
            }
        }
        // Ids are created children first, so id order is a topological order.
        out.sort_unstable();
        out
    }

    fn poly_uncached(&mut self, pool: &mut Pool, id: ExprId) -> Poly {
        match pool.node(id) {
            Node::Num(bits) => constant(f64::from_bits(bits)),
            Node::Leaf(_) => atom(id),
            Node::Neg(a) => {
                let mut p = Poly::clone(&self.poly(pool, a));
                p.scale(-1.0);
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
        let mut terms = Vec::with_capacity(inner.len());
        for (m, c) in inner.iter() {
            let (constant, varying): (Monomial, Monomial) = m
                .iter()
                .copied()
                .partition(|(k, _)| matches!(pool.node(*k), Node::Leaf(Leaf::Param(_))));
            let varying_expr = if varying.is_empty() {
                pool.leaf(Leaf::Time)
            } else {
                let body = rebuild(pool, &Poly::single(varying, 1.0));
                pool.int(body)
            };
            let term = mul(&constant_poly(constant, *c), &atom(varying_expr));
            terms.extend(term.0);
        }
        Poly::from_terms(terms)
    }

    fn binary(&mut self, pool: &mut Pool, op: BinOp, a: ExprId, b: ExprId, whole: ExprId) -> Poly {
        match op {
            BinOp::Add | BinOp::Sub => self.sum(pool, whole),
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
                    None => Poly::clone(&p), // division by zero: keep the numerator, flagged by NaN below
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
                        Poly::single([(sum, n)].into_iter().collect(), lead.powi(n))
                    }
                    Some(e) => {
                        let n = e as i32;
                        let mut out = constant(1.0);
                        let factor = if n >= 0 {
                            Some(Poly::clone(&base))
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

    /// A chain of `+` and `-` as one sum. A canonical form is rebuilt as a left-nested
    /// chain, so caching the polynomial of every prefix `t1 + … + tk` would store n²/2
    /// terms for n; the prefixes are walked through instead (unless already cached).
    fn sum(&mut self, pool: &mut Pool, whole: ExprId) -> Poly {
        let mut operands = Vec::new();
        let mut node = whole;
        loop {
            match pool.node(node) {
                Node::Binary(op @ (BinOp::Add | BinOp::Sub), a, b)
                    if node == whole || !self.polys.contains_key(&node) =>
                {
                    operands.push((b, if op == BinOp::Add { 1.0 } else { -1.0 }));
                    node = a;
                }
                _ => {
                    operands.push((node, 1.0));
                    break;
                }
            }
        }
        // From the leftmost operand on, so like terms add up in the order they always did.
        let mut terms = Vec::new();
        for (operand, sign) in operands.into_iter().rev() {
            let p = self.poly(pool, operand);
            terms.extend(p.iter().map(|(m, &c)| (m.clone(), sign * c)));
        }
        Poly::from_terms(terms)
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
            Some(Poly::single(inv, 1.0 / c))
        }
        _ => {
            let (lead, sum) = normalised_sum(pool, q);
            Some(Poly::single([(sum, -1)].into_iter().collect(), 1.0 / lead))
        }
    }
}

/// A sum as `lead · S` with S's leading coefficient 1, so 2a + 2b and a + b share the atom S.
fn normalised_sum(pool: &mut Pool, q: &Poly) -> (f64, ExprId) {
    let lead = q.iter().next().map_or(1.0, |(_, c)| *c);
    let mut scaled = q.clone();
    scaled.0.iter_mut().for_each(|(_, c)| *c /= lead);
    (lead, rebuild(pool, &scaled))
}

/// The polynomial as an expression: terms in canonical order, negative powers as a quotient.
pub(super) fn rebuild(pool: &mut Pool, poly: &Poly) -> ExprId {
    let mut terms: Vec<(bool, ExprId)> = Vec::with_capacity(poly.len());
    // Constant last, as people write it.
    let mut ordered: Vec<(&Monomial, &f64)> = poly.iter().filter(|(m, _)| !m.is_empty()).collect();
    ordered.extend(poly.iter().filter(|(m, _)| m.is_empty()));
    for (m, &c) in ordered {
        // The coefficient first, then the atoms: 4 * K * j0, not 4 * (K * j0).
        let magnitude = pool.num(c.abs());
        let mut numerator: Option<ExprId> = (c.abs() != 1.0).then_some(magnitude);
        let mut denominator: Option<ExprId> = None;
        for &(a, e) in m.iter() {
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

    /// The sigmoid's derivative from the chain rule, three fractions over (E + 1) and
    /// (E + 1)^2, is one: g E/(E+1)^2 + g E/(E+1) - g E^2/(E+1)^2 = 2 g E/(E+1)^2; a term
    /// without a denominator stays outside.
    #[test]
    fn fractions_over_a_common_sum_are_put_together() {
        let mut p = Pool::default();
        let (g, x, y) = (
            p.leaf(Leaf::Param(ParamId(0))),
            p.leaf(Leaf::Param(ParamId(1))),
            p.leaf(Leaf::Param(ParamId(2))),
        );
        let e = p.call(crate::expr::Func::Exp, &[x]);
        let one = p.num(1.0);
        let two = p.num(2.0);
        let s = p.add(e, one);
        let s2 = p.pow(s, two);
        let ge = p.mul(g, e);
        let a = p.div(ge, s2);
        let b = p.div(ge, s);
        let e2 = p.pow(e, two);
        let ge2 = p.mul(g, e2);
        let c = p.div(ge2, s2);
        let ab = p.add(a, b);
        let abc = p.sub(ab, c);
        let sum = p.add(abc, y);
        let mut simplifier = Simplifier::default();
        let together = simplifier.together(&mut p, sum);
        let text = crate::symbolic::Printer::new(&p, |l| match l {
            Leaf::Param(ParamId(0)) => "g".to_string(),
            Leaf::Param(ParamId(1)) => "x".to_string(),
            _ => "y".to_string(),
        })
        .text(together);
        assert_eq!(text, "2 * g * exp(x) / (exp(x) + 1) ^ 2 + y");
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
