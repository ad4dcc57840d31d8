//! Freeing the redundant equations of torn unknowns, so that each ARR stays local.
//!
//! In diagnosis, the balance of a measured junction that computes an unknown (a force
//! between two measured masses, say) does not pass that value on: the unknown is held as a
//! symbol `u` (see [`crate::causality::solve::Torn`]). Substituting its value everywhere
//! would be exact, but the value carries everything upstream of the junction, and in a chain
//! the k-th ARR would then hold derivatives of order about 2k of the first detector.
//!
//! So a value is substituted only when it was computed from known signals alone. Otherwise,
//! where `u` enters linearly with constant coefficients, each equation that holds it reads
//! `c(D) u + rest = 0`, with `D` = d/dt and `c` a polynomial in `D` whose coefficients are
//! parameter expressions. Such operators commute, so a pivot `a(D) u + ra = 0` removes `u`
//! from `t(D) u + rt = 0` as `t(D) ra − a(D) rt = 0` (or `ra − rt` when `t = a`): Gaussian
//! elimination over polynomials in `D`. The pivot is not `u`'s own definition, and holds the
//! fewest other torn unknowns, so each result combines neighbouring parts of the graph only.
//! Where `u` enters nonlinearly, or with a coefficient that varies in time, its value is
//! substituted: the classic elimination along causal paths, exact for any law.
//!
//! All of it is done on canonical polynomials ([`Polynomial`]), so an ARR comes out in
//! canonical form and the cost of a step is the size of the polynomials it touches.

use std::collections::{BTreeSet, HashMap};

use super::auxiliary::Auxiliary;
use super::operator::{common_factor, common_known_factor, divide, normalised, Operator};
use crate::causality::solve::Torn;
use crate::index::Idx as _;
use crate::symbolic::{
    known_signal_rule, AuxIx, Derivatives, ExprId, Leaf, Node, Polynomial, Pool, Simplifier, VarId,
};

/// A relation `expr = 0` over known signals.
#[derive(Clone, Debug)]
pub(crate) struct Constraint {
    /// The residual, in canonical form.
    pub expr: ExprId,
    /// The model equations it was combined from.
    pub equations: BTreeSet<usize>,
    /// The equation it is attributed to: the last redundant equation combined into it.
    pub origin: usize,
}

/// The relations left once every torn unknown is gone, and what could not be done.
pub(crate) struct Eliminated {
    /// The ARRs.
    pub relations: Vec<Constraint>,
    /// Torn unknowns (by index) that enter their relations nonlinearly after their value
    /// stopped being explicit: the relations that held them are dropped.
    pub problems: Vec<VarId>,
    /// Torn unknowns whose relations would differentiate a `sign()` of a moving signal (a
    /// dry friction's law, `abs`, `min` or `max` past their first derivative): its
    /// derivative is an impulse at each zero crossing, not 0, so those relations are dropped.
    pub non_smooth: Vec<VarId>,
    /// The auxiliary signals the relations may read ([`Leaf::Aux`] by index), with their
    /// definitions only.
    pub auxiliaries: Vec<Auxiliary>,
}

/// One equation during elimination: `poly = 0`.
struct Item {
    poly: Polynomial,
    equations: BTreeSet<usize>,
    origin: usize,
    /// The torn unknown this equation computed.
    computes: Option<VarId>,
    /// That unknown and its value, while the equation still reads `u − value = 0`.
    defines: Option<(VarId, Polynomial)>,
    /// Whether that value was computed from known signals alone, without other torn
    /// unknowns: then substituting it keeps the relations it enters local.
    local: bool,
    /// The torn unknowns the equation holds now.
    torn: BTreeSet<VarId>,
}

/// `c(D) u + rest`, with `coefficients[k]` the coefficient of the k-th derivative of `u`.
struct Linear {
    coefficients: Vec<Polynomial>,
    rest: Polynomial,
}

/// Pivot operators kept as candidate factors: a bound, so a long chain stays linear.
const MAX_FACTORS: usize = 16;

/// The longest operator (degree + 1) kept as a candidate factor.
const MAX_FACTOR_LEN: usize = 5;

/// The most products of terms (of an operator's coefficients by a relation's known part)
/// that applying the operator may multiply out; beyond, the known part is named as an
/// auxiliary signal. Small enough that two stretches of a chain with parameters of their own
/// are never multiplied together, large enough that no model of `models/` needs one.
const MAX_EXPANDED: usize = 20_000;

type Rule = fn(&mut Pool, Leaf) -> Option<ExprId>;

/// The elimination state: the pool, and the memos of canonical forms and of d/dt.
struct Eliminator<'p> {
    pool: &'p mut Pool,
    /// The pivots' operators met so far (monic), tried as common factors of later ones.
    factors: Vec<Operator>,
    simplifier: Simplifier,
    derivatives: Derivatives<Leaf, Rule>,
    /// The auxiliary signals named so far.
    auxiliaries: Vec<Auxiliary>,
}

/// Eliminates the `torn` unknowns from their definitions and the `redundant` equations
/// (equation index, residual), in the order they were torn.
pub(crate) fn eliminate(
    pool: &mut Pool,
    torn: &[Torn],
    redundant: &[(usize, ExprId)],
) -> Eliminated {
    let mut e = Eliminator::new(pool);
    let mut items: Vec<Option<Item>> = Vec::with_capacity(torn.len() + redundant.len());
    for t in torn {
        let Some((equation, value)) = t.definition else {
            continue;
        };
        let u = e.pool.leaf(Leaf::Tear(t.var, 0));
        let expr = e.pool.sub(u, value);
        let value = e.simplifier.polynomial(e.pool, value);
        let local = e.torn_in(&value).is_empty();
        items.push(Some(e.item(expr, equation, Some((t.var, value)), local)));
    }
    for &(equation, expr) in redundant {
        items.push(Some(e.item(expr, equation, None, false)));
    }
    let mut holders_of: HashMap<VarId, BTreeSet<usize>> = HashMap::new();
    for (i, item) in items.iter().enumerate() {
        for &w in item.iter().flat_map(|it| &it.torn) {
            holders_of.entry(w).or_default().insert(i);
        }
    }
    let (mut problems, mut non_smooth) = (Vec::new(), Vec::new());
    for t in torn {
        let u = t.var;
        let holders: Vec<usize> = holders_of
            .remove(&u)
            .unwrap_or_default()
            .into_iter()
            .filter(|&i| items[i].as_ref().is_some_and(|it| it.torn.contains(&u)))
            .collect();
        let eliminated = e.eliminate_one(&mut items, &holders, u);
        if e.derivatives.take_non_smooth() {
            non_smooth.push(u);
        } else if !eliminated {
            problems.push(u);
        }
        e.simplifier.forget_polynomials();
        for &i in &holders {
            let Some(item) = &mut items[i] else { continue };
            item.torn = e.torn_in(&item.poly);
            for &w in &item.torn {
                holders_of.entry(w).or_default().insert(i);
            }
        }
    }
    let relations = items
        .into_iter()
        .flatten()
        .filter(|it| it.torn.is_empty())
        .map(|it| Constraint {
            expr: it.poly.expr(e.pool),
            equations: it.equations,
            origin: it.origin,
        })
        .collect();
    Eliminated {
        relations,
        problems,
        non_smooth,
        auxiliaries: e.auxiliaries,
    }
}

impl<'p> Eliminator<'p> {
    fn new(pool: &'p mut Pool) -> Self {
        Eliminator {
            pool,
            factors: Vec::new(),
            simplifier: Simplifier::default(),
            derivatives: Derivatives::new(known_signal_rule as Rule).exact(),
            auxiliaries: Vec::new(),
        }
    }

    fn item(
        &mut self,
        expr: ExprId,
        equation: usize,
        defines: Option<(VarId, Polynomial)>,
        local: bool,
    ) -> Item {
        let poly = self.simplifier.polynomial(self.pool, expr);
        Item {
            torn: self.torn_in(&poly),
            poly,
            equations: BTreeSet::from([equation]),
            origin: equation,
            computes: defines.as_ref().map(|d| d.0),
            defines,
            local,
        }
    }

    /// The torn unknowns a polynomial holds, in its atoms or inside them.
    fn torn_in(&self, p: &Polynomial) -> BTreeSet<VarId> {
        p.atoms().flat_map(|a| self.torn_in_atom(a)).collect()
    }

    /// The torn unknowns an atom is or holds.
    fn torn_in_atom(&self, a: ExprId) -> Vec<VarId> {
        match self.pool.node(a) {
            Node::Leaf(Leaf::Tear(v, _)) => vec![v],
            Node::Leaf(_) => Vec::new(),
            _ => self
                .pool
                .leaves(a)
                .into_iter()
                .filter_map(|l| match l {
                    Leaf::Tear(v, _) => Some(v),
                    _ => None,
                })
                .collect(),
        }
    }

    /// Removes `u` from every holder: by substituting its value when that is local, by a
    /// pivot when all hold it linearly, else by substitution again. Holders that would keep
    /// `u` are dropped, and `false` returned.
    fn eliminate_one(&mut self, items: &mut [Option<Item>], holders: &[usize], u: VarId) -> bool {
        if holders.len() < 2 {
            // Only its own definition (or one equation) holds it: nothing to relate.
            for &i in holders {
                items[i] = None;
            }
            return true;
        }
        let definition = holders
            .iter()
            .copied()
            .find(|&i| items[i].as_ref().is_some_and(|it| it.computes == Some(u)));
        if definition.is_some_and(|d| items[d].as_ref().is_some_and(|it| it.local)) {
            return self.by_substitution(items, holders, definition, u);
        }
        let forms: Option<Vec<Linear>> = holders
            .iter()
            .map(|&i| self.linear(&items[i].as_ref()?.poly, u))
            .collect();
        let pivot = forms.as_ref().and_then(|forms| {
            (0..holders.len())
                .filter(|&k| Some(holders[k]) != definition)
                .min_by_key(|&k| {
                    let others = items[holders[k]]
                        .as_ref()
                        .map_or(usize::MAX, |it| it.torn.iter().filter(|&&w| w != u).count());
                    (others, forms[k].coefficients.len(), holders[k])
                })
        });
        match (forms, pivot) {
            (Some(forms), Some(p)) => self.by_pivot(items, holders, &forms, p),
            _ => self.by_substitution(items, holders, definition, u),
        }
    }

    /// `p` as `c(D) u + rest`, if `u` enters it linearly with constant coefficients.
    fn linear(&self, p: &Polynomial, u: VarId) -> Option<Linear> {
        let (coefficients, rest) = p.split_linear(self.pool, |l| match l {
            Leaf::Tear(v, n) if v == u => Some(n),
            _ => None,
        })?;
        let constant = |c: &Polynomial| {
            c.atoms()
                .all(|a| matches!(self.pool.node(a), Node::Leaf(Leaf::Param(_))))
        };
        coefficients
            .iter()
            .all(constant)
            .then_some(Linear { coefficients, rest })
    }

    fn by_pivot(
        &mut self,
        items: &mut [Option<Item>],
        holders: &[usize],
        forms: &[Linear],
        p: usize,
    ) -> bool {
        let Some(pivot) = items[holders[p]].take() else {
            return false;
        };
        for (k, &i) in holders.iter().enumerate() {
            if k == p {
                continue;
            }
            let Some(combined) = self.combine(&forms[p], &forms[k]) else {
                items[i] = None;
                return false;
            };
            let Some(item) = items[i].as_mut() else {
                continue;
            };
            item.poly = combined;
            item.equations.extend(pivot.equations.iter().copied());
            item.origin = pivot.origin;
            item.defines = None;
        }
        true
    }

    /// `t(D) ra − a(D) rt`, with the common factor of `a` and `t` dropped, so that a unit
    /// coefficient gives exactly the substitution and shared operators cost no derivatives.
    fn combine(&mut self, pivot: &Linear, target: &Linear) -> Option<Polynomial> {
        let (a, t) = (&pivot.coefficients, &target.coefficients);
        let top = a.len().checked_sub(1)?;
        let proportional =
            a.len() == t.len() && (0..top).all(|k| t[k].times(&a[top]) == a[k].times(&t[top]));
        if proportional {
            // t = λ a: a(D) (λ ra − rt) = 0, and a(D) is dropped.
            let scaled = if t[top] == a[top] {
                target.rest.clone()
            } else if let Some(ratio) = a[top].over_monomial(&t[top]) {
                target.rest.times(&ratio)
            } else {
                return Some(
                    pivot
                        .rest
                        .times(&t[top])
                        .plus(&target.rest.times(&a[top]), -1.0),
                );
            };
            return Some(pivot.rest.plus(&scaled, -1.0));
        }
        // With g = gcd(a, t): (t/g) ra − (a/g) rt, the same combination of the two
        // equations with deg g fewer derivatives (see `operator`).
        let g = common_factor(a, t).or_else(|| common_known_factor(a, t, &self.factors));
        let reduced = g.and_then(|g| Some((divide(t, &g)?, divide(a, &g)?)));
        if let Some(f) = normalised(a).filter(|f| f.len() <= MAX_FACTOR_LEN) {
            if !self.factors.contains(&f) {
                // The most recent ones: in a chain, the neighbours' operators.
                if self.factors.len() == MAX_FACTORS {
                    self.factors.remove(0);
                }
                self.factors.push(f);
            }
        }
        let (t, a) = match &reduced {
            Some((t, a)) => (t.as_slice(), a.as_slice()),
            None => (t.as_slice(), a.as_slice()),
        };
        let left = self.apply(t, &pivot.rest)?;
        let right = self.apply(a, &target.rest)?;
        Some(left.plus(&right, -1.0))
    }

    /// `c(D) e`, with the part of `e` free of torn unknowns named as an auxiliary signal `z`
    /// (`Σ c_k z⁽ᵏ⁾`) when multiplying it out would cost more than [`MAX_EXPANDED`].
    fn apply(&mut self, c: &[Polynomial], e: &Polynomial) -> Option<Polynomial> {
        if c.len() < 2 {
            return self.multiply_out(c, e);
        }
        let (known, rest) = e.partition(|a| self.torn_in_atom(a).is_empty());
        let weight: usize = c.iter().map(Polynomial::terms).sum();
        if known.terms() < 2 || known.terms().saturating_mul(weight) <= MAX_EXPANDED {
            return self.multiply_out(c, e);
        }
        let k = AuxIx::new(self.auxiliaries.len());
        let definition = known.expr(self.pool);
        self.auxiliaries.push(Auxiliary::new(definition));
        let mut out = self.multiply_out(c, &rest)?;
        for (n, cn) in c.iter().enumerate() {
            let z = self.pool.leaf(Leaf::Aux(k, u32::try_from(n).ok()?));
            let z = self.simplifier.polynomial(self.pool, z);
            out.add_scaled(&cn.times(&z), 1.0);
        }
        Some(out)
    }

    /// `c(D) e` = Σ c_k dᵏe/dtᵏ, multiplied out.
    fn multiply_out(&mut self, c: &[Polynomial], e: &Polynomial) -> Option<Polynomial> {
        let mut out = Polynomial::default();
        let mut dk = e.clone();
        for (k, ck) in c.iter().enumerate() {
            if k > 0 {
                dk = self.d(&dk)?;
            }
            if !ck.is_zero() {
                out.add_scaled(&ck.times(&dk), 1.0);
            }
        }
        Some(out)
    }

    fn d(&mut self, p: &Polynomial) -> Option<Polynomial> {
        self.simplifier
            .derivative(self.pool, p, &mut self.derivatives)
    }

    /// Replaces `u` and its derivatives by its definition's value in every other holder.
    fn by_substitution(
        &mut self,
        items: &mut [Option<Item>],
        holders: &[usize],
        definition: Option<usize>,
        u: VarId,
    ) -> bool {
        let value = definition.and_then(|d| match &items[d].as_ref()?.defines {
            Some((w, value)) if *w == u => Some(value.clone()),
            _ => None,
        });
        let (Some(d), Some(value)) = (definition, value) else {
            for &i in holders {
                items[i] = None;
            }
            return false;
        };
        let Some(def) = items[d].take() else {
            return true;
        };
        let mut derivatives = vec![value];
        for &i in holders {
            let Some(mut item) = items[i].take() else {
                continue;
            };
            let Some(poly) = self.substitute(&item.poly, u, &mut derivatives) else {
                return false;
            };
            item.poly = poly;
            if let Some((w, own)) = item.defines.take() {
                let Some(own) = self.substitute(&own, u, &mut derivatives) else {
                    return false;
                };
                item.defines = Some((w, own));
            }
            item.equations.extend(def.equations.iter().copied());
            items[i] = Some(item);
        }
        true
    }

    /// `p` with the k-th derivative of `u` replaced by `derivatives[k]` (extended as needed).
    fn substitute(
        &mut self,
        p: &Polynomial,
        u: VarId,
        derivatives: &mut Vec<Polynomial>,
    ) -> Option<Polynomial> {
        let var = |l: Leaf| match l {
            Leaf::Tear(v, n) if v == u => Some(n),
            _ => None,
        };
        if let Some((coefficients, rest)) = p.split_linear(self.pool, var) {
            let mut out = rest;
            for (k, c) in coefficients.iter().enumerate() {
                while derivatives.len() <= k {
                    let next = self.d(&derivatives[derivatives.len() - 1])?;
                    derivatives.push(next);
                }
                out.add_scaled(&c.times(&derivatives[k]), 1.0);
            }
            return Some(out);
        }
        if !self.torn_in(p).contains(&u) {
            return Some(p.clone());
        }
        // Nonlinear in u: substitute in the expression, then back to canonical form.
        let expr = p.expr(self.pool);
        let value = derivatives[0].expr(self.pool);
        let mut values: Vec<ExprId> = vec![value];
        let top = self
            .pool
            .leaves(expr)
            .into_iter()
            .filter_map(&var)
            .max()
            .unwrap_or(0);
        for _ in 0..top {
            let next = self.derivatives.of(self.pool, values[values.len() - 1])?;
            values.push(next);
        }
        let substituted = self.pool.substitute(expr, &mut |_, l| {
            var(l).and_then(|n| values.get(n as usize).copied())
        });
        Some(self.simplifier.polynomial(self.pool, substituted))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{NodeId, ParamId};

    fn sensor(pool: &mut Pool, i: usize, n: u32) -> ExprId {
        pool.leaf(Leaf::Sensor(NodeId(petgraph::graph::NodeIndex::new(i)), n))
    }

    /// The relation left when `pivot = 0` removes the torn unknown 0 from `target = 0`.
    fn combined(pool: &mut Pool, pivot: ExprId, target: ExprId) -> ExprId {
        let mut e = Eliminator::new(pool);
        let (pa, pt) = (
            e.simplifier.polynomial(e.pool, pivot),
            e.simplifier.polynomial(e.pool, target),
        );
        let (la, lt) = (
            e.linear(&pa, VarId(0)).expect("linear"),
            e.linear(&pt, VarId(0)).expect("linear"),
        );
        e.combine(&la, &lt).expect("combines").expr(e.pool)
    }

    /// `k·u' + u − y1 = 0` and `u' − y2 = 0` give `−y1' + y2 + k·y2' = 0`: from the second
    /// u' = y2, from the first u = y1 − k·y2, so y2 = u' = y1' − k·y2'.
    #[test]
    fn a_pivot_removes_the_unknown_by_operators_in_d() {
        let mut pool = Pool::default();
        let k = pool.leaf(Leaf::Param(ParamId(0)));
        let (u, du) = (
            pool.leaf(Leaf::Tear(VarId(0), 0)),
            pool.leaf(Leaf::Tear(VarId(0), 1)),
        );
        let (y1, y2) = (sensor(&mut pool, 1, 0), sensor(&mut pool, 2, 0));
        let kdu = pool.mul(k, du);
        let a = pool.add(kdu, u);
        let a = pool.sub(a, y1);
        let t = pool.sub(du, y2);
        let out = combined(&mut pool, a, t);
        let (dy1, dy2) = (sensor(&mut pool, 1, 1), sensor(&mut pool, 2, 1));
        let kdy2 = pool.mul(k, dy2);
        let want = pool.sub(y2, dy1);
        let want = pool.add(want, kdy2);
        let mut s = Simplifier::default();
        assert_eq!(s.simplify(&mut pool, out), s.simplify(&mut pool, want));
    }

    /// Equal operators cancel instead of multiplying: `k·u' − y1 = 0` and `k·u' − y2 = 0`
    /// give `y2 − y1 = 0`, of order 0, not `k·(y2' − y1')`.
    #[test]
    fn equal_operators_are_dropped_not_multiplied() {
        let mut pool = Pool::default();
        let k = pool.leaf(Leaf::Param(ParamId(0)));
        let du = pool.leaf(Leaf::Tear(VarId(0), 1));
        let (y1, y2) = (sensor(&mut pool, 1, 0), sensor(&mut pool, 2, 0));
        let kdu = pool.mul(k, du);
        let (a, t) = (pool.sub(kdu, y1), pool.sub(kdu, y2));
        let out = combined(&mut pool, a, t);
        let want = pool.sub(y2, y1);
        let mut s = Simplifier::default();
        assert_eq!(s.simplify(&mut pool, out), s.simplify(&mut pool, want));
    }

    /// A coefficient that varies in time (`y1·u`) or a nonlinear use (`u²`) is not linear with
    /// constant coefficients: such unknowns are substituted, never pivoted on.
    #[test]
    fn time_varying_or_nonlinear_uses_are_not_linear() {
        let mut pool = Pool::default();
        let u = pool.leaf(Leaf::Tear(VarId(0), 0));
        let y1 = sensor(&mut pool, 1, 0);
        let two = pool.num(2.0);
        let cases = [pool.mul(y1, u), pool.pow(u, two)];
        let mut e = Eliminator::new(&mut pool);
        for case in cases {
            let p = e.simplifier.polynomial(e.pool, case);
            assert!(e.linear(&p, VarId(0)).is_none());
        }
    }
}
