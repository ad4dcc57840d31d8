//! Numeric evaluation of expressions.

use super::hash::FastMap;
use super::pool::{ExprId, LeafKind, Node, Pool};
use crate::expr::{BinOp, Func};
use crate::index::{typed_index, Idx as _};
use std::collections::HashMap;

/// Evaluates expressions of one pool with leaf values from a closure, memoising shared nodes.
pub struct Evaluator<'p, L: LeafKind, F> {
    pool: &'p Pool<L>,
    leaf: F,
    /// Values of the nodes evaluated so far: sparse, so that an evaluator costs what it
    /// reaches, not the size of its pool.
    values: FastMap<ExprId<L>, f64>,
    integrals: HashMap<ExprId<L>, f64>,
}

impl<'p, L: LeafKind, F: Fn(L) -> f64> Evaluator<'p, L, F> {
    /// An evaluator over `pool`, reading leaves with `leaf`.
    pub fn new(pool: &'p Pool<L>, leaf: F) -> Self {
        Evaluator {
            pool,
            leaf,
            values: FastMap::default(),
            integrals: HashMap::new(),
        }
    }

    /// Gives the current values of `int(..)` nodes, which cannot be evaluated pointwise.
    pub fn with_integrals(mut self, integrals: HashMap<ExprId<L>, f64>) -> Self {
        self.integrals = integrals;
        self
    }

    /// The value of `root`.
    pub fn value(&mut self, root: ExprId<L>) -> f64 {
        // Only what is not yet evaluated is visited: evaluating many roots that share parts
        // (the terms of one residual) costs what is new in each.
        let order = self
            .pool
            .reachable_unless(root, |id| self.values.contains_key(&id));
        for id in order {
            let node = self.pool.node(id);
            // Children come first in `order` or were evaluated before.
            let v = |x: ExprId<L>| self.values[&x];
            let value = match node {
                Node::Num(bits) => f64::from_bits(bits),
                Node::Leaf(l) => (self.leaf)(l),
                Node::Neg(a) => -v(a),
                Node::Binary(op, a, b) => op.apply(v(a), v(b)),
                Node::Call1(f, a) => f.apply(&[v(a)]),
                Node::Call2(f, a, b) => f.apply(&[v(a), v(b)]),
                Node::Int(_) => match self.integrals.get(&id) {
                    Some(&value) => value,
                    // An integral no value was given for has none.
                    None => f64::NAN,
                },
            };
            self.values.insert(id, value);
        }
        self.values[&root]
    }
}

/// One step of a [`Tape`]: a node with its children as positions in the tape.
#[derive(Clone, Copy, Debug)]
enum Op<L> {
    Num(f64),
    Leaf(L),
    Neg(Slot),
    Add(Slot, Slot),
    Sub(Slot, Slot),
    Mul(Slot, Slot),
    Div(Slot, Slot),
    /// A power with a whole exponent, as the generated code writes it (`powi`): the two
    /// agree to the bit, and it costs a few multiplications instead of a logarithm.
    Powi(Slot, i32),
    Pow(Slot, Slot),
    Call1(Func, Slot),
    Call2(Func, Slot, Slot),
    /// An integral, by its node in the pool: its value comes from outside.
    Int(u32),
}

/// Expressions of a pool compiled into a straight-line program, children first: evaluating
/// them at many points (every step of a simulation) is one pass over an array, with no
/// hashing, instead of a walk of the DAG per point.
#[derive(Clone, Debug)]
pub struct Tape<L: LeafKind> {
    ops: Vec<Op<L>>,
    /// The position of each root's value.
    roots: Vec<Slot>,
}

typed_index! {
    /// The place of an operation's value on a [`Tape`].
    struct Slot;
}

/// The step for `a op b` at `slots`, `exponent` the node of `b`: a whole exponent below 64
/// in size is raised as the generated Rust raises it.
fn binary<L: LeafKind>(
    pool: &Pool<L>,
    op: BinOp,
    (a, b): (Slot, Slot),
    exponent: ExprId<L>,
) -> Op<L> {
    match op {
        BinOp::Add => Op::Add(a, b),
        BinOp::Sub => Op::Sub(a, b),
        BinOp::Mul => Op::Mul(a, b),
        BinOp::Div => Op::Div(a, b),
        BinOp::Pow => match pool.node(exponent) {
            Node::Num(bits) => {
                let n = f64::from_bits(bits);
                if n.fract() == 0.0 && n.abs() < 64.0 {
                    Op::Powi(a, n as i32)
                } else {
                    Op::Pow(a, b)
                }
            }
            _ => Op::Pow(a, b),
        },
    }
}

impl<L: LeafKind> Tape<L> {
    /// The program that evaluates `roots` of `pool`.
    pub fn new(pool: &Pool<L>, roots: &[ExprId<L>]) -> Tape<L> {
        let mut position: FastMap<ExprId<L>, Slot> = FastMap::default();
        let mut ops = Vec::new();
        pool.visit_reachable(roots, |id, node| {
            // Children come first: each is placed before its parent.
            let at = |x: ExprId<L>| position.get(&x).copied().unwrap_or(Slot(0));
            let op = match node {
                Node::Num(bits) => Op::Num(f64::from_bits(bits)),
                Node::Leaf(l) => Op::Leaf(l),
                Node::Neg(a) => Op::Neg(at(a)),
                Node::Binary(op, a, b) => binary(pool, op, (at(a), at(b)), b),
                Node::Call1(f, a) => Op::Call1(f, at(a)),
                Node::Call2(f, a, b) => Op::Call2(f, at(a), at(b)),
                Node::Int(_) => Op::Int(id.index() as u32),
            };
            position.insert(id, Slot::new(ops.len()));
            ops.push(op);
        });
        let roots = roots.iter().map(|r| position[r]).collect();
        Tape { ops, roots }
    }

    /// The values of the roots, in order, with leaves read by `leaf` and each integral's
    /// current value by `integral`; `scratch` is reused between calls.
    pub fn values(
        &self,
        leaf: impl Fn(L) -> f64,
        integral: impl Fn(ExprId<L>) -> f64,
        scratch: &mut Vec<f64>,
    ) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.roots.len());
        self.values_into(leaf, integral, scratch, &mut out);
        out
    }

    /// [`Tape::values`] into `out` (cleared first), with no allocation once `scratch` and
    /// `out` have grown to size.
    pub fn values_into(
        &self,
        leaf: impl Fn(L) -> f64,
        integral: impl Fn(ExprId<L>) -> f64,
        scratch: &mut Vec<f64>,
        out: &mut Vec<f64>,
    ) {
        // Written by position rather than pushed: a push reloads the length every time. Every
        // step is written before it is read (children come first), so the scratch is sized,
        // not cleared.
        if scratch.len() != self.ops.len() {
            scratch.clear();
            scratch.resize(self.ops.len(), 0.0);
        }
        let s = scratch.as_mut_slice();
        for (i, op) in self.ops.iter().enumerate() {
            let value = match *op {
                Op::Num(x) => x,
                Op::Leaf(l) => leaf(l),
                Op::Neg(a) => -s[a.index()],
                Op::Add(a, b) => s[a.index()] + s[b.index()],
                Op::Sub(a, b) => s[a.index()] - s[b.index()],
                Op::Mul(a, b) => s[a.index()] * s[b.index()],
                Op::Div(a, b) => s[a.index()] / s[b.index()],
                Op::Powi(a, n) => s[a.index()].powi(n),
                Op::Pow(a, b) => s[a.index()].powf(s[b.index()]),
                Op::Call1(f, a) => f.apply(&[s[a.index()]]),
                Op::Call2(f, a, b) => f.apply(&[s[a.index()], s[b.index()]]),
                Op::Int(id) => integral(ExprId::from_index(id)),
            };
            s[i] = value;
        }
        out.clear();
        out.extend(self.roots.iter().map(|&r| s[r.index()]));
    }

    /// [`Tape::values_into`] at `n` points at once, each step over all of them before the
    /// next (arithmetic the processor runs as vectors): `leaf` fills a leaf's `n` values,
    /// `integral` an integral's; root `r`'s values end up in `out[r·n..(r + 1)·n]`. Each
    /// point's values are those `values_into` gives, to the bit.
    pub fn columns_into(
        &self,
        n: usize,
        mut leaf: impl FnMut(L, &mut [f64]),
        mut integral: impl FnMut(ExprId<L>, &mut [f64]),
        scratch: &mut Vec<f64>,
        out: &mut Vec<f64>,
    ) {
        // As in `values_into`, every step's column is written before it is read.
        let len = self.ops.len() * n;
        if scratch.len() < len {
            scratch.resize(len, 0.0);
        }
        for (i, op) in self.ops.iter().enumerate() {
            // Children come first: their columns are all below this one's.
            let (done, rest) = scratch.split_at_mut(i * n);
            let to = &mut rest[..n];
            let at = |a: Slot| &done[a.index() * n..][..n];
            match *op {
                Op::Num(x) => to.fill(x),
                Op::Leaf(l) => leaf(l, to),
                Op::Neg(a) => map(to, at(a), |x| -x),
                Op::Add(a, b) => map2(to, at(a), at(b), |x, y| x + y),
                Op::Sub(a, b) => map2(to, at(a), at(b), |x, y| x - y),
                Op::Mul(a, b) => map2(to, at(a), at(b), |x, y| x * y),
                Op::Div(a, b) => map2(to, at(a), at(b), |x, y| x / y),
                // The square by itself: `powi` with an exponent known only at run time is a
                // call, and squaring by multiplication is what it computes.
                Op::Powi(a, 2) => map(to, at(a), |x| x * x),
                Op::Powi(a, k) => map(to, at(a), |x| x.powi(k)),
                Op::Pow(a, b) => map2(to, at(a), at(b), f64::powf),
                Op::Call1(f, a) => map(to, at(a), |x| f.apply(&[x])),
                Op::Call2(f, a, b) => map2(to, at(a), at(b), |x, y| f.apply(&[x, y])),
                Op::Int(id) => integral(ExprId::from_index(id), to),
            }
        }
        out.clear();
        for r in &self.roots {
            out.extend_from_slice(&scratch[r.index() * n..][..n]);
        }
    }
}

/// `to[i] = f(a[i])` for every point.
#[inline(always)]
fn map(to: &mut [f64], a: &[f64], f: impl Fn(f64) -> f64) {
    for (to, &a) in to.iter_mut().zip(a) {
        *to = f(a);
    }
}

/// `to[i] = f(a[i], b[i])` for every point.
#[inline(always)]
fn map2(to: &mut [f64], a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> f64) {
    for ((to, &a), &b) in to.iter_mut().zip(a).zip(b) {
        *to = f(a, b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind of step, shared subexpressions and all: each point of `columns_into` is
    /// what `values_into` gives at that point alone, to the bit.
    #[test]
    fn columns_are_the_points_values_to_the_bit() {
        let mut p: Pool<u8> = Pool::default();
        let (x, y) = (p.leaf(0), p.leaf(1));
        let (two, half, three) = (p.num(2.0), p.num(0.5), p.num(3.0));
        let sq = p.pow(x, two);
        let root = p.pow(y, half);
        let xy = p.mul(x, y);
        let quotient = p.div(sq, xy);
        let e = p.call(Func::Exp, &[quotient]);
        let m = p.call(Func::Max, &[x, y]);
        let diff = p.sub(e, m);
        let neg = p.neg(root);
        let sum = p.add(diff, neg);
        let size = p.call(Func::Abs, &[sum]);
        let powered = p.pow(size, x);
        let cubed = p.pow(powered, three);
        let integral = p.int(x);
        let with_int = p.add(cubed, integral);
        let roots = [with_int, sum, sq];
        let tape = Tape::new(&p, &roots);
        let points: Vec<[f64; 2]> = (0..37)
            .map(|k| [0.1 + 0.07 * k as f64, 1.3 - 0.02 * k as f64])
            .collect();
        let n = points.len();
        let (mut scratch, mut out) = (Vec::new(), Vec::new());
        tape.columns_into(
            n,
            |l, to| {
                for (to, v) in to.iter_mut().zip(&points) {
                    *to = v[usize::from(l)];
                }
            },
            |_, to| {
                for (to, v) in to.iter_mut().zip(&points) {
                    *to = v[0] * 10.0;
                }
            },
            &mut scratch,
            &mut out,
        );
        assert_eq!(out.len(), roots.len() * n);
        for (i, v) in points.iter().enumerate() {
            let one = tape.values(|l| v[usize::from(l)], |_| v[0] * 10.0, &mut Vec::new());
            for (r, value) in one.iter().enumerate() {
                assert!(value.is_finite(), "{value} at {v:?}");
                assert_eq!(
                    out[r * n + i].to_bits(),
                    value.to_bits(),
                    "root {r} at {v:?}"
                );
            }
        }
    }
}
