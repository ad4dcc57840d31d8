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
}
