//! Whether a residual really depends on a parameter: its partial derivative, evaluated in
//! forward mode (dual numbers) at random points of the signals' space, is not zero.
//!
//! A parameter that survives simplification as a leaf may still cancel (a factor common to
//! a numerator and a denominator): the FSM must not mark it. A polynomial or rational
//! function that is not identically zero is non-zero at a random point with probability one
//! (Schwartz–Zippel), so three points from a fixed-seed generator decide, the same way on
//! every run.

use std::collections::HashMap;

use crate::expr::{BinOp, Func};
use crate::graph::{BondGraph, ParamId};
use crate::symbolic::hash::FastMap;
use crate::symbolic::{ExprId, Leaf, Node, Pool};

/// Points tried; a dependence is found at the first where the derivative is not zero.
const POINTS: u64 = 3;

/// Relative size below which a partial derivative counts as zero (round-off).
const ZERO: f64 = 1e-9;

/// Whether `root` depends on parameter `theta`, judged at random points.
pub fn depends_on(pool: &Pool, root: ExprId, theta: ParamId, model: &BondGraph) -> bool {
    let mut inside_integral = false;
    pool.visit_reachable(&[root], |_, node| {
        if let Node::Int(a) = node {
            inside_integral |= pool.leaves(a).contains(&Leaf::Param(theta));
        }
    });
    if inside_integral {
        // Integrals are atoms here; what is inside one is taken as it is written.
        return true;
    }
    (0..POINTS).any(|seed| {
        let (slope, size) = Point::new(seed, model).dual(pool, root, theta);
        // Round-off is relative to the slopes of the terms that cancel, not to the residual's
        // value: parameters and signals come in every unit (2e-11 m^3/Pa next to 1 m^3/s).
        !slope.is_finite() || (size > 0.0 && slope.abs() > ZERO * size)
    })
}

/// Random values for every leaf, from a fixed seed.
struct Point<'m> {
    seed: u64,
    model: &'m BondGraph,
}

impl Point<'_> {
    fn new(seed: u64, model: &BondGraph) -> Point<'_> {
        Point { seed, model }
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

    /// A parameter: its nominal value scaled by a random factor (never zero when nominal is
    /// not), so that a dependence hidden at the nominal values (a balanced bridge) still shows.
    fn param(&self, p: ParamId) -> f64 {
        let nominal = self.model.params[p.0 as usize].value;
        let base = if nominal == 0.0 { 1.0 } else { nominal };
        base * self.uniform(u64::from(p.0) << 8 | 1)
    }

    fn leaf(&self, leaf: Leaf) -> f64 {
        let key = match leaf {
            Leaf::Param(p) => return self.param(p),
            Leaf::Input(u, n) => (u64::from(u.0) << 16 | u64::from(n)) << 8 | 2,
            Leaf::Sensor(s, n) => ((s.0.index() as u64) << 16 | u64::from(n)) << 8 | 3,
            Leaf::State(k) => u64::from(k) << 8 | 4,
            Leaf::Var(v) => u64::from(v) << 8 | 5,
            Leaf::Tear(v, n) => (u64::from(v) << 16 | u64::from(n)) << 8 | 6,
            Leaf::Time => 7,
        };
        // Signals may be negative: centre them on zero.
        2.0 * self.uniform(key) - 2.0
    }

    /// The derivative of `root` in `theta`, and its gross size: the same derivative with
    /// every contribution counted by its absolute value, so that what cancels, inside a
    /// term or between terms, shows as a derivative far below its gross size.
    fn dual(&self, pool: &Pool, root: ExprId, theta: ParamId) -> (f64, f64) {
        let mut memo: FastMap<ExprId, Dual> = FastMap::default();
        let mut integrals: HashMap<ExprId, f64> = HashMap::new();
        pool.visit_reachable(&[root], |id, node| {
            let get = |x: ExprId| memo.get(&x).copied().unwrap_or(Dual::constant(f64::NAN));
            let d = match node {
                Node::Num(bits) => Dual::constant(f64::from_bits(bits)),
                Node::Leaf(l) if l == Leaf::Param(theta) => Dual {
                    value: self.leaf(l),
                    slope: 1.0,
                    gross: 1.0,
                },
                Node::Leaf(l) => Dual::constant(self.leaf(l)),
                Node::Neg(a) => {
                    let a = get(a);
                    Dual {
                        value: -a.value,
                        slope: -a.slope,
                        gross: a.gross,
                    }
                }
                Node::Binary(op, a, b) => binary(op, get(a), get(b)),
                Node::Call1(f, a) => call1(f, get(a)),
                Node::Call2(f, a, b) => {
                    let (x, y) = (get(a), get(b));
                    let first = match f {
                        Func::Min => x.value <= y.value,
                        _ => x.value >= y.value,
                    };
                    if first {
                        x
                    } else {
                        y
                    }
                }
                Node::Int(_) => {
                    let n = integrals.len() as u64;
                    let v = *integrals
                        .entry(id)
                        .or_insert_with(|| 2.0 * self.uniform(n << 8 | 9) - 2.0);
                    Dual::constant(v)
                }
            };
            memo.insert(id, d);
        });
        memo.get(&root)
            .map_or((f64::NAN, 0.0), |d| (d.slope, d.gross))
    }
}

/// A value, its derivative in one parameter, and that derivative's gross size.
#[derive(Clone, Copy)]
struct Dual {
    value: f64,
    slope: f64,
    gross: f64,
}

impl Dual {
    fn constant(value: f64) -> Self {
        Dual {
            value,
            slope: 0.0,
            gross: 0.0,
        }
    }
}

fn binary(op: BinOp, a: Dual, b: Dual) -> Dual {
    let (x, y) = (a.value, b.value);
    match op {
        BinOp::Add | BinOp::Sub => {
            let sign = if op == BinOp::Add { 1.0 } else { -1.0 };
            Dual {
                value: x + sign * y,
                slope: a.slope + sign * b.slope,
                gross: a.gross + b.gross,
            }
        }
        BinOp::Mul => Dual {
            value: x * y,
            slope: a.slope * y + x * b.slope,
            gross: a.gross * y.abs() + x.abs() * b.gross,
        },
        BinOp::Div => Dual {
            value: x / y,
            slope: (a.slope * y - x * b.slope) / (y * y),
            gross: (a.gross * y.abs() + x.abs() * b.gross) / (y * y),
        },
        BinOp::Pow => {
            let v = x.powf(y);
            let (dx, dy) = (y * x.powf(y - 1.0), v * x.abs().ln());
            Dual {
                value: v,
                slope: dx * a.slope + if b.slope == 0.0 { 0.0 } else { dy * b.slope },
                gross: dx.abs() * a.gross
                    + if b.gross == 0.0 {
                        0.0
                    } else {
                        dy.abs() * b.gross
                    },
            }
        }
    }
}

fn call1(f: Func, a: Dual) -> Dual {
    let x = a.value;
    let v = f.apply(&[x]);
    let outer = match f {
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
        Func::Min | Func::Max => 1.0,
    };
    Dual {
        value: v,
        slope: outer * a.slope,
        gross: outer.abs() * a.gross,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::InputId;

    /// `(a u + a v)/a - u - v + b w` is `b w`: it depends on b, not on a, although a is
    /// written three times; and a tiny parameter next to large signals is still seen.
    #[test]
    fn a_parameter_that_cancels_is_not_a_dependence() {
        let (model, d) = crate::load(
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
        let minus_u = p.sub(ratio, u);
        let minus_v = p.sub(minus_u, v);
        let bw = p.mul(b, w);
        let r = p.add(minus_v, bw);
        assert!(!depends_on(&p, r, ParamId(0), &model));
        assert!(depends_on(&p, r, ParamId(1), &model));
    }
}
