//! Whether a residual's zeros move with a parameter: the partial derivative of the ratio of
//! its values at two random points (the same parameters, other signals), evaluated in
//! reverse mode (adjoints, all parameters in one pass), is not zero. The ratio leaves out a
//! factor of parameters that only scales the whole residual.
//!
//! A parameter that survives simplification as a leaf may still cancel (a factor common to
//! a numerator and a denominator): the FSM must not mark it. A polynomial or rational
//! function that is not identically zero is non-zero at a random point with probability one
//! (Schwartz–Zippel), so three points from a fixed-seed generator decide, the same way on
//! every run.

use std::collections::BTreeSet;

use crate::expr::{BinOp, Func};
use crate::graph::{BondGraph, ParamId};
use crate::symbolic::hash::FastMap;
use crate::symbolic::{ExprId, Leaf, Node, Pool};

/// Points tried; a dependence is found at the first where the derivative is not zero.
const POINTS: u64 = 3;

/// Relative size below which a partial derivative counts as zero (round-off).
const ZERO: f64 = 1e-9;

/// The parameters `root` depends on, judged at random points: one reverse (adjoint) pass per
/// point gives the derivative in every parameter at once, so the cost is the size of the
/// residual, not that times its number of parameters.
pub(super) fn dependences(pool: &Pool, root: ExprId, model: &BondGraph) -> BTreeSet<ParamId> {
    let mut found = BTreeSet::new();
    pool.visit_reachable(&[root], |_, node| {
        if let Node::Int(a) = node {
            // Integrals are atoms here; what is inside one is taken as it is written.
            found.extend(pool.leaves(a).into_iter().filter_map(|l| match l {
                Leaf::Param(p) => Some(p),
                _ => None,
            }));
        }
    });
    for seed in 0..POINTS {
        // Two points with the same parameters and other signals: what decides is the ratio
        // of the residual's values, so that a factor of parameters multiplying the whole
        // residual (a scale, which does not move its zeros) marks nothing.
        let (value_a, at_a) = Point::new(seed, 0, model).adjoints(pool, root);
        let (value_b, at_b) = Point::new(seed, 1, model).adjoints(pool, root);
        let of = |at: &[(ParamId, f64, f64)], p: ParamId| {
            at.iter()
                .find(|(q, _, _)| *q == p)
                .map_or((0.0, 0.0), |&(_, d, g)| (d, g))
        };
        for &(p, _, _) in at_a.iter().chain(&at_b) {
            let ((da, ga), (db, gb)) = (of(&at_a, p), of(&at_b, p));
            // d(a/b)/dθ · b² = a' b − a b', with its gross size.
            let slope = da * value_b - value_a * db;
            let size = ga * value_b.abs() + value_a.abs() * gb;
            // Round-off is relative to the slopes of the terms that cancel, not to the
            // residual's value: parameters and signals come in every unit (2e-11 m^3/Pa next
            // to 1 m^3/s).
            if !slope.is_finite() || (size > 0.0 && slope.abs() > ZERO * size) {
                found.insert(p);
            }
        }
    }
    found
}

/// Random values for every leaf, from a fixed seed.
struct Point<'m> {
    seed: u64,
    /// Which draw of the signals (the parameters are the same for every draw of a seed).
    draw: u64,
    model: &'m BondGraph,
}

impl Point<'_> {
    fn new(seed: u64, draw: u64, model: &BondGraph) -> Point<'_> {
        Point { seed, draw, model }
    }

    /// A value in [0.5, 1.5) from a hash of the seed and a key: the same key gets the same
    /// value at one point, whatever the order of evaluation.
    fn uniform(&self, key: u64) -> f64 {
        let mut x = key ^ self.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        x ^= x >> 33;
        x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        x ^= x >> 33;
        x = x.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        x ^= x >> 33;
        0.5 + (x >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A parameter: a random value of the size the signals have, not its nominal one. A
    /// dependence is an algebraic property, and the nominal values hide it twice over: at
    /// special values (a balanced bridge) and by units (with `A = 2e-3 m²`, `Cf = 2e-11`,
    /// `k = 2e5`, a term in `A²` is 1e-13 of its residual at signals of size one and reads
    /// as round-off).
    fn param(&self, p: ParamId) -> f64 {
        debug_assert!((p.index()) < self.model.params.len());
        self.uniform(u64::from(p.0) << 8 | 1)
    }

    fn leaf(&self, leaf: Leaf) -> f64 {
        let key = match leaf {
            Leaf::Param(p) => return self.param(p),
            Leaf::Input(u, n) => (u64::from(u.0) << 16 | u64::from(n)) << 8 | 2,
            Leaf::Sensor(s, n) => ((s.0.index() as u64) << 16 | u64::from(n)) << 8 | 3,
            Leaf::State(k) => u64::from(k.0) << 8 | 4,
            Leaf::Var(v) => u64::from(v.0) << 8 | 5,
            Leaf::Tear(v, n) => (u64::from(v.0) << 16 | u64::from(n)) << 8 | 6,
            Leaf::Aux(k, n) => (u64::from(k.0) << 16 | u64::from(n)) << 8 | 8,
            Leaf::Root(k, n) => (u64::from(k.0) << 16 | u64::from(n)) << 8 | 9,
            Leaf::Time => 7,
        };
        self.signal(key)
    }

    /// A signal's value (or an integral's), of this draw: centred on zero, since signals
    /// may be negative.
    fn signal(&self, key: u64) -> f64 {
        2.0 * self.uniform(key ^ self.draw.wrapping_mul(0xA24B_AED4_963E_E407)) - 2.0
    }

    /// The value of `root`, and each parameter leaf of it with the derivative of `root` in it and that
    /// derivative's gross size: the same derivative with every contribution counted by its
    /// absolute value, so that what cancels, inside a term or between terms, shows as a
    /// derivative far below its gross size.
    fn adjoints(&self, pool: &Pool, root: ExprId) -> (f64, Vec<(ParamId, f64, f64)>) {
        let mut order: Vec<(ExprId, Node)> = Vec::new();
        pool.visit_reachable(&[root], |id, node| order.push((id, node)));
        let index: FastMap<ExprId, usize> = order
            .iter()
            .enumerate()
            .map(|(i, (id, _))| (*id, i))
            .collect();
        let mut value = vec![f64::NAN; order.len()];
        let mut integrals = 0u64;
        for (i, &(_, node)) in order.iter().enumerate() {
            let get = |x: ExprId| index.get(&x).map_or(f64::NAN, |&k| value[k]);
            value[i] = match node {
                Node::Num(bits) => f64::from_bits(bits),
                Node::Leaf(l) => self.leaf(l),
                Node::Neg(a) => -get(a),
                Node::Binary(op, a, b) => op.apply(get(a), get(b)),
                Node::Call1(f, a) => f.apply(&[get(a)]),
                Node::Call2(f, a, b) => f.apply(&[get(a), get(b)]),
                Node::Int(_) => {
                    integrals += 1;
                    self.signal(integrals << 8 | 9)
                }
            };
        }
        // Adjoints, parents before children: (derivative, gross size).
        let mut adjoint = vec![(0.0f64, 0.0f64); order.len()];
        if let Some(last) = adjoint.last_mut() {
            *last = (1.0, 1.0);
        }
        let mut out = Vec::new();
        for i in (0..order.len()).rev() {
            let (s, g) = adjoint[i];
            if s == 0.0 && g == 0.0 {
                continue;
            }
            let node = order[i].1;
            let at = |x: ExprId| index.get(&x).copied();
            let val = |x: ExprId| at(x).map_or(f64::NAN, |k| value[k]);
            let mut give = |x: ExprId, local: f64| {
                if let Some(k) = at(x) {
                    adjoint[k].0 += s * local;
                    adjoint[k].1 += g * local.abs();
                }
            };
            match node {
                Node::Leaf(Leaf::Param(p)) => out.push((p, s, g)),
                Node::Num(_) | Node::Leaf(_) | Node::Int(_) => {}
                Node::Neg(a) => give(a, -1.0),
                Node::Binary(op, a, b) => {
                    let (x, y) = (val(a), val(b));
                    match op {
                        BinOp::Add => {
                            give(a, 1.0);
                            give(b, 1.0);
                        }
                        BinOp::Sub => {
                            give(a, 1.0);
                            give(b, -1.0);
                        }
                        BinOp::Mul => {
                            give(a, y);
                            give(b, x);
                        }
                        BinOp::Div => {
                            give(a, 1.0 / y);
                            give(b, -x / (y * y));
                        }
                        BinOp::Pow => {
                            let v = x.powf(y);
                            give(a, y * x.powf(y - 1.0));
                            if pool.leaves(b).iter().any(|l| matches!(l, Leaf::Param(_))) {
                                give(b, v * x.abs().ln());
                            }
                        }
                    }
                }
                Node::Call1(f, a) => give(a, outer(f, val(a))),
                Node::Call2(f, a, b) => {
                    let (x, y) = (val(a), val(b));
                    let first = match f {
                        Func::Min => x <= y,
                        _ => x >= y,
                    };
                    give(if first { a } else { b }, 1.0);
                }
            }
        }
        // `root` is reached last: the order ends with it.
        (value[order.len() - 1], out)
    }
}

/// The derivative of `f` at `x`.
fn outer(f: Func, x: f64) -> f64 {
    let v = f.apply(&[x]);
    match f {
        Func::Exp => v,
        Func::Log => 1.0 / x,
        Func::Sqrt => 0.5 / v,
        Func::Abs => x.signum(),
        Func::Sign => 0.0,
        Func::Sin => x.cos(),
        Func::Cos => -x.sin(),
        Func::Tan => 1.0 + v * v,
        Func::Tanh => 1.0 - v * v,
        Func::Atan => 1.0 / (1.0 + x * x),
        Func::Atanh => 1.0 / (1.0 - x * x),
        Func::Min | Func::Max => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::InputId;

    /// `(a u + a v)/a - v + b w` is `u + b w`: it depends on b, not on a, although a is
    /// written three times; and a parameter tiny in its unit (b = 2e-11) is still seen.
    #[test]
    fn a_parameter_that_cancels_is_not_a_dependence() {
        let (model, d) = crate::graph::load(
            "model t\nparam a = 3\nparam b = 2e-11\ninput U\nSe s = U\nR r = a\nR q = b\nu -> 1:j -> r, q\n"
                .replace("u ->", "s ->")
                .as_str(),
        );
        let model = model.unwrap_or_else(|| panic!("{d:?}"));
        let mut p = Pool::default();
        let (a, b) = (
            p.leaf(Leaf::Param(ParamId(0))),
            p.leaf(Leaf::Param(ParamId(1))),
        );
        let [u, v, w] = [0, 1, 2].map(|k| p.leaf(Leaf::Input(InputId(k), 0)));
        let (au, av) = (p.mul(a, u), p.mul(a, v));
        let sum = p.add(au, av);
        let ratio = p.div(sum, a);
        let minus_v = p.sub(ratio, v);
        let bw = p.mul(b, w);
        let r = p.add(minus_v, bw);
        let found = dependences(&p, r, &model);
        assert!(!found.contains(&ParamId(0)), "a cancels");
        assert!(found.contains(&ParamId(1)), "b is seen");
        // (a + b)(u - b v): a only scales the residual, its zeros do not move with it.
        let ab = p.add(a, b);
        let bv = p.mul(b, v);
        let diff = p.sub(u, bv);
        let scaled = p.mul(ab, diff);
        let found = dependences(&p, scaled, &model);
        assert!(!found.contains(&ParamId(0)), "a is a scale");
        assert!(found.contains(&ParamId(1)), "b moves the zeros");
    }
}
