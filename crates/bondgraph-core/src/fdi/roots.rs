//! The roots an ARR reads, made evaluable: a root `z` of `g(z, t) = 0` (a law with no
//! closed-form inverse, read for its input) moves at `z' = −(∂g/∂t)/(∂g/∂z)`, so every
//! derivative of it is an expression in `z` itself and in known signals. Put back that way,
//! an ARR asks a residual generator for one thing per root and sample: a root of `g`.

use crate::causality::solve::Root;
use crate::index::Idx as _;
use crate::symbolic::{known_signal_rule, Derivatives, ExprId, Leaf, Pool, RootIx};

/// A root as a residual generator solves it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RootLaw {
    /// `g`, zero at the root: over known signals, earlier roots and the root itself
    /// ([`Leaf::Root`] of order 0 only).
    pub residual: ExprId,
    /// `∂g/∂z`, for Newton's method.
    pub slope: ExprId,
    /// Its time derivatives as far as the ARRs read them, each over known signals and the
    /// roots' values: `derivatives[0]` is the root's leaf.
    pub derivatives: Vec<ExprId>,
}

/// Each root's derivatives, in terms of the roots themselves.
pub(crate) struct Explicit {
    /// `table[k][n]`: the n-th derivative of root `k` (`table[k][0]` is its leaf).
    table: Vec<Vec<ExprId>>,
    /// The laws, in root order.
    pub laws: Vec<RootLaw>,
}

/// Makes the roots of `roots` evaluable: their laws, with the derivatives of earlier roots
/// put back. `None` if a law cannot be differentiated.
pub(crate) fn explicit(pool: &mut Pool, roots: &[Root]) -> Option<Explicit> {
    let mut e = Explicit {
        table: Vec::with_capacity(roots.len()),
        laws: Vec::with_capacity(roots.len()),
    };
    for (k, root) in roots.iter().enumerate() {
        let k = RootIx::new(k);
        let g = e.put_back(pool, root.residual)?;
        let z = pool.leaf(Leaf::Root(k, 0));
        // ∂g/∂t with z held: every other leaf moves as it does.
        let rates: Vec<ExprId> = e.table.iter().map(|t| t[1]).collect();
        let mut moving = Derivatives::new(move |p: &mut Pool, leaf: Leaf| match leaf {
            Leaf::Root(j, 0) if j == k => Some(p.num(0.0)),
            Leaf::Root(j, 0) => rates.get(j.index()).copied(),
            Leaf::Root(..) => None,
            other => known_signal_rule(p, other),
        });
        let dt = moving.of(pool, g)?;
        let mut partial = Derivatives::partial(move |p: &mut Pool, leaf: Leaf| {
            Some(p.num(if leaf == Leaf::Root(k, 0) { 1.0 } else { 0.0 }))
        });
        let slope = partial.of(pool, g)?;
        let ratio = pool.div(dt, slope);
        let rate = pool.neg(ratio);
        e.table.push(vec![z, rate]);
        e.laws.push(RootLaw {
            residual: g,
            slope,
            derivatives: Vec::new(),
        });
    }
    Some(e)
}

impl Explicit {
    /// The laws, each with the derivatives of its root that `exprs` read (directly or
    /// through the derivatives of other roots). `None` if one cannot be differentiated.
    pub(crate) fn laws_for(&mut self, pool: &mut Pool, exprs: &[ExprId]) -> Option<Vec<RootLaw>> {
        let mut top: Vec<u32> = vec![0; self.laws.len()];
        let mut stack: Vec<ExprId> = exprs.to_vec();
        while let Some(e) = stack.pop() {
            for leaf in pool.leaves(e) {
                let Leaf::Root(k, n) = leaf else { continue };
                let t = top.get_mut(k.index())?;
                if n > *t {
                    self.extend(pool, k, n)?;
                    stack.extend(
                        self.table[k.index()][*t as usize + 1..=n as usize]
                            .iter()
                            .copied(),
                    );
                    *t = n;
                }
            }
        }
        // One order more than read: realised by integration, a relation reads a root where
        // it read its derivative, and a product rule may then read the next one.
        for (k, &t) in top.iter().enumerate() {
            self.extend(pool, RootIx::new(k), t + 1)?;
        }
        let mut laws = std::mem::take(&mut self.laws);
        for (law, (t, table)) in laws.iter_mut().zip(top.iter().zip(&self.table)) {
            law.derivatives = table[..=*t as usize + 1].to_vec();
        }
        Some(laws)
    }

    /// `e` with every derivative of a root replaced by its expression in the roots.
    pub(crate) fn put_back(&mut self, pool: &mut Pool, e: ExprId) -> Option<ExprId> {
        for leaf in pool.leaves(e) {
            if let Leaf::Root(k, n @ 1..) = leaf {
                self.extend(pool, k, n)?;
            }
        }
        let table = &self.table;
        Some(pool.substitute(e, &mut |_, leaf| match leaf {
            Leaf::Root(k, n) if n > 0 => table.get(k.index())?.get(n as usize).copied(),
            _ => None,
        }))
    }

    /// Gives root `k` its derivatives up to order `n`.
    fn extend(&mut self, pool: &mut Pool, k: RootIx, n: u32) -> Option<()> {
        let rates: Vec<ExprId> = self.table.iter().map(|t| t[1]).collect();
        let mut rule = Derivatives::new(move |p: &mut Pool, leaf: Leaf| match leaf {
            Leaf::Root(j, 0) => rates.get(j.index()).copied(),
            Leaf::Root(..) => None,
            other => known_signal_rule(p, other),
        });
        let derivatives = self.table.get_mut(k.index())?;
        while derivatives.len() <= n as usize {
            let last = derivatives[derivatives.len() - 1];
            derivatives.push(rule.of(pool, last)?);
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::causality::equations::VarId;
    use crate::graph::{InputId, ParamId};
    use crate::symbolic::Evaluator;

    /// For `g = k z + z³ − u(t)`, the derivatives put back agree with finite differences of
    /// the root found by bisection, with `u = 2 + sin t`.
    #[test]
    fn a_roots_derivatives_follow_it() {
        let mut pool = Pool::default();
        let z = pool.leaf(Leaf::Root(RootIx(0), 0));
        let k = pool.leaf(Leaf::Param(ParamId(0)));
        let u = pool.leaf(Leaf::Input(InputId(0), 0));
        let kz = pool.mul(k, z);
        let three = pool.num(3.0);
        let z3 = pool.pow(z, three);
        let law = pool.add(kz, z3);
        let residual = pool.sub(law, u);
        let roots = [Root {
            var: VarId(0),
            equation: 0,
            residual,
        }];
        let mut e = explicit(&mut pool, &roots).expect("differentiable");
        let second = pool.leaf(Leaf::Root(RootIx(0), 2));
        let second = e.put_back(&mut pool, second).expect("differentiable");
        let root_at = |t: f64| {
            let target = 2.0 + t.sin();
            let (mut lo, mut hi) = (-10.0_f64, 10.0_f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if 1.5 * mid + mid.powi(3) > target {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        };
        for t in [0.2, 1.0, 2.5] {
            let value = |x: ExprId| {
                Evaluator::new(&pool, &|leaf| match leaf {
                    Leaf::Root(RootIx(0), 0) => root_at(t),
                    Leaf::Param(_) => 1.5,
                    Leaf::Input(_, 0) => 2.0 + t.sin(),
                    Leaf::Input(_, 1) => t.cos(),
                    Leaf::Input(_, 2) => -t.sin(),
                    _ => f64::NAN,
                })
                .value(x)
            };
            let h = 1e-4;
            let numeric = (root_at(t + h) - 2.0 * root_at(t) + root_at(t - h)) / (h * h);
            let exact = value(second);
            assert!(
                (exact - numeric).abs() < 1e-4,
                "t = {t}: {exact} vs {numeric}"
            );
            assert!(value(e.laws[0].residual).abs() < 1e-12);
            assert!((value(e.laws[0].slope) - (1.5 + 3.0 * root_at(t).powi(2))).abs() < 1e-9);
        }
    }
}
