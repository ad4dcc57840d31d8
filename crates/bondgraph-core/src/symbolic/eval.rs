//! Numeric evaluation of expressions.

use super::hash::FastMap;
use super::pool::{ExprId, LeafKind, Node, Pool};
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
            let v = |x: ExprId<L>| self.values.get(&x).copied().unwrap_or(f64::NAN);
            let value = match node {
                Node::Num(bits) => f64::from_bits(bits),
                Node::Leaf(l) => (self.leaf)(l),
                Node::Neg(a) => -v(a),
                Node::Binary(op, a, b) => op.apply(v(a), v(b)),
                Node::Call1(f, a) => f.apply(&[v(a)]),
                Node::Call2(f, a, b) => f.apply(&[v(a), v(b)]),
                Node::Int(_) => self.integrals.get(&id).copied().unwrap_or(f64::NAN),
            };
            self.values.insert(id, value);
        }
        self.values.get(&root).copied().unwrap_or(f64::NAN)
    }
}
