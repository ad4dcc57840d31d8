//! Nodes of the expression DAG and their hash-consing constructors.

use std::fmt;
use std::hash::Hash;
use std::marker::PhantomData;

use super::hash::{FastMap, FastSet};

use crate::expr::{BinOp, Func};
use crate::graph::{InputId, NodeId, ParamId};
use crate::index::typed_index;

typed_index! {
    /// A root of the solved system (an unknown a law without a closed-form inverse sets),
    /// by its place among the roots.
    pub struct RootIx;
}

typed_index! {
    /// An auxiliary signal of a diagnosis, by its place among them.
    pub struct AuxIx;
}

typed_index! {
    /// A state variable (momentum of an `I`, displacement of a `C`), by its place among the
    /// model's states.
    pub struct StateIx;
}

typed_index! {
    /// An unknown of an equation system, by its place among the system's unknowns.
    pub struct VarId;
}

/// An expression: a handle into a [`Pool`] whose leaves are `L`. Children always have smaller
/// ids than parents. The leaf type ties a handle to its kind of pool: a solver's expression
/// cannot be read in the product's pool.
pub struct ExprId<L = Leaf>(u32, PhantomData<fn() -> L>);

impl<L> ExprId<L> {
    /// The handle at position `index` of its pool.
    pub(crate) const fn from_index(index: u32) -> Self {
        ExprId(index, PhantomData)
    }

    /// Its position in its pool, for dense side tables.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl<L> Clone for ExprId<L> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<L> Copy for ExprId<L> {}
impl<L> PartialEq for ExprId<L> {
    fn eq(&self, other: &Self) -> bool {
        self.0 == other.0
    }
}
impl<L> Eq for ExprId<L> {}
impl<L> PartialOrd for ExprId<L> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<L> Ord for ExprId<L> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.cmp(&other.0)
    }
}
impl<L> Hash for ExprId<L> {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.hash(state);
    }
}
impl<L> fmt::Debug for ExprId<L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ExprId({})", self.0)
    }
}

/// What a pool's leaves must be: small values that can be hashed and ordered.
pub trait LeafKind: Copy + Eq + Ord + Hash + fmt::Debug {}
impl<T: Copy + Eq + Ord + Hash + fmt::Debug> LeafKind for T {}

/// A leaf of an expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Leaf {
    /// A model parameter.
    Param(ParamId),
    /// The `n`-th time derivative of a known input.
    Input(InputId, u32),
    /// The `n`-th time derivative of a measured signal.
    Sensor(NodeId, u32),
    /// A state variable (momentum of an `I`, displacement of a `C`), by index.
    State(StateIx),
    /// An unknown of an equation system, by index, until it is substituted away.
    Var(VarId),
    /// The `n`-th time derivative of an unknown held as a symbol (a differential tear, by
    /// the index of the unknown), until the ARRs are freed of it.
    Tear(VarId, u32),
    /// The `n`-th time derivative of an auxiliary signal (by index): a combination of known
    /// signals that an elimination step applies an operator in d/dt to, named instead of
    /// multiplied out (see `fdi::auxiliary`).
    Aux(AuxIx, u32),
    /// The `n`-th time derivative of an unknown that a law without a closed-form inverse
    /// sets implicitly (by the index of its root in the solved system): solved numerically
    /// at run time, its derivatives put back in terms of it once the ARRs are derived.
    Root(RootIx, u32),
    /// Time.
    Time,
}

impl Pool<Leaf> {
    /// Whether `a` holds parameters and numbers only: a constant of the model.
    pub fn is_constant(&self, a: ExprId) -> bool {
        self.leaves(a).iter().all(|l| matches!(l, Leaf::Param(_)))
    }
}

/// One node of the DAG, with leaves of type `L`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node<L: LeafKind = Leaf> {
    /// A number, by its bits (so nodes can be hashed); never NaN from a constructor.
    Num(u64),
    /// A leaf.
    Leaf(L),
    /// `-a`
    Neg(ExprId<L>),
    /// `a op b`
    Binary(BinOp, ExprId<L>, ExprId<L>),
    /// `f(a)`
    Call1(Func, ExprId<L>),
    /// `f(a, b)`
    Call2(Func, ExprId<L>, ExprId<L>),
    /// The time integral of `a` from the start of the record.
    Int(ExprId<L>),
}

/// The arena of expression nodes, each stored once.
#[derive(Clone, Debug)]
pub struct Pool<L: LeafKind = Leaf> {
    nodes: Vec<Node<L>>,
    index: FastMap<Node<L>, ExprId<L>>,
}

impl<L: LeafKind> Default for Pool<L> {
    fn default() -> Self {
        Pool {
            nodes: Vec::new(),
            index: FastMap::default(),
        }
    }
}

impl<L: LeafKind> Pool<L> {
    /// The node of `id`.
    pub fn node(&self, id: ExprId<L>) -> Node<L> {
        self.nodes[id.index()]
    }

    /// Number of distinct nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the pool is empty.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    fn intern(&mut self, node: Node<L>) -> ExprId<L> {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = ExprId::from_index(self.nodes.len() as u32);
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// A number.
    pub fn num(&mut self, x: f64) -> ExprId<L> {
        // One zero, so `0` and `-0` share a node.
        let x = if x == 0.0 { 0.0 } else { x };
        self.intern(Node::Num(x.to_bits()))
    }

    /// The value of `id` if it is a number.
    pub fn as_num(&self, id: ExprId<L>) -> Option<f64> {
        match self.node(id) {
            Node::Num(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// A leaf.
    pub fn leaf(&mut self, leaf: L) -> ExprId<L> {
        self.intern(Node::Leaf(leaf))
    }

    /// `-a`
    pub fn neg(&mut self, a: ExprId<L>) -> ExprId<L> {
        match self.node(a) {
            Node::Num(bits) => self.num(-f64::from_bits(bits)),
            Node::Neg(x) => x,
            Node::Binary(BinOp::Sub, x, y) => self.intern(Node::Binary(BinOp::Sub, y, x)),
            _ => self.intern(Node::Neg(a)),
        }
    }

    /// `a + b`
    pub fn add(&mut self, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        match (self.as_num(a), self.as_num(b)) {
            (Some(x), Some(y)) => self.num(x + y),
            (Some(0.0), _) => b,
            (_, Some(0.0)) => a,
            _ => match self.node(b) {
                Node::Neg(y) => self.intern(Node::Binary(BinOp::Sub, a, y)),
                _ => self.intern(Node::Binary(BinOp::Add, a, b)),
            },
        }
    }

    /// `a - b`
    pub fn sub(&mut self, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        if a == b {
            return self.num(0.0);
        }
        match (self.as_num(a), self.as_num(b)) {
            (Some(x), Some(y)) => self.num(x - y),
            (Some(0.0), _) => self.neg(b),
            (_, Some(0.0)) => a,
            _ => match self.node(b) {
                Node::Neg(y) => self.intern(Node::Binary(BinOp::Add, a, y)),
                _ => self.intern(Node::Binary(BinOp::Sub, a, b)),
            },
        }
    }

    /// `a * b`
    pub fn mul(&mut self, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        match (self.as_num(a), self.as_num(b)) {
            (Some(x), Some(y)) => self.num(x * y),
            (Some(0.0), _) | (_, Some(0.0)) => self.num(0.0),
            (Some(1.0), _) => b,
            (_, Some(1.0)) => a,
            (Some(-1.0), _) => self.neg(b),
            (_, Some(-1.0)) => self.neg(a),
            _ => match (self.node(a), self.node(b)) {
                (Node::Neg(x), Node::Neg(y)) => self.mul(x, y),
                (Node::Neg(x), _) => {
                    let m = self.mul(x, b);
                    self.neg(m)
                }
                (_, Node::Neg(y)) => {
                    let m = self.mul(a, y);
                    self.neg(m)
                }
                _ => self.intern(Node::Binary(BinOp::Mul, a, b)),
            },
        }
    }

    /// `a / b`
    pub fn div(&mut self, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        match (self.as_num(a), self.as_num(b)) {
            (Some(x), Some(y)) if y != 0.0 => self.num(x / y),
            (Some(0.0), _) => self.num(0.0),
            (_, Some(1.0)) => a,
            (_, Some(-1.0)) => self.neg(a),
            _ => match (self.node(a), self.node(b)) {
                // (1 / x) / y stays readable as 1 / (x * y); x / (1 / y) is x * y.
                (_, Node::Binary(BinOp::Div, one, y)) if self.as_num(one) == Some(1.0) => {
                    self.mul(a, y)
                }
                (Node::Neg(x), _) => {
                    let d = self.div(x, b);
                    self.neg(d)
                }
                _ => self.intern(Node::Binary(BinOp::Div, a, b)),
            },
        }
    }

    /// `a ^ b`
    pub fn pow(&mut self, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        match (self.as_num(a), self.as_num(b)) {
            (Some(x), Some(y)) => self.num(x.powf(y)),
            (_, Some(1.0)) => a,
            (_, Some(0.0)) => self.num(1.0),
            _ => self.intern(Node::Binary(BinOp::Pow, a, b)),
        }
    }

    /// `a op b`
    pub fn binary(&mut self, op: BinOp, a: ExprId<L>, b: ExprId<L>) -> ExprId<L> {
        match op {
            BinOp::Add => self.add(a, b),
            BinOp::Sub => self.sub(a, b),
            BinOp::Mul => self.mul(a, b),
            BinOp::Div => self.div(a, b),
            BinOp::Pow => self.pow(a, b),
        }
    }

    /// `f(a)` or `f(a, b)`; constant arguments are folded.
    pub fn call(&mut self, func: Func, args: &[ExprId<L>]) -> ExprId<L> {
        let values: Option<Vec<f64>> = args.iter().map(|&a| self.as_num(a)).collect();
        if let Some(values) = values {
            let v = func.apply(&values);
            if v.is_finite() {
                return self.num(v);
            }
        }
        match args {
            [a] => self.intern(Node::Call1(func, *a)),
            [a, b, ..] => self.intern(Node::Call2(func, *a, *b)),
            [] => self.num(f64::NAN),
        }
    }

    /// The time integral of `a`.
    pub fn int(&mut self, a: ExprId<L>) -> ExprId<L> {
        match self.as_num(a) {
            Some(0.0) => a,
            _ => self.intern(Node::Int(a)),
        }
    }

    /// Sum of signed terms (`true` = plus); zero when empty.
    pub fn signed_sum(&mut self, terms: &[(bool, ExprId<L>)]) -> ExprId<L> {
        let mut acc: Option<ExprId<L>> = None;
        for &(plus, t) in terms {
            acc = Some(match (acc, plus) {
                (None, true) => t,
                (None, false) => self.neg(t),
                (Some(a), true) => self.add(a, t),
                (Some(a), false) => self.sub(a, t),
            });
        }
        acc.unwrap_or_else(|| self.num(0.0))
    }

    /// Calls `f` on every node reachable from `roots`, children before parents, once each.
    /// Costs O(r log r) for r reachable nodes, whatever the size of the pool.
    pub fn visit_reachable(&self, roots: &[ExprId<L>], mut f: impl FnMut(ExprId<L>, Node<L>)) {
        let mut seen: FastSet<ExprId<L>> = FastSet::default();
        let mut stack: Vec<ExprId<L>> = roots.to_vec();
        let mut found = Vec::new();
        while let Some(id) = stack.pop() {
            if !seen.insert(id) {
                continue;
            }
            found.push(id);
            stack.extend(children(self.node(id)));
        }
        // Ids are created children first, so id order is a topological order.
        found.sort_unstable();
        for id in found {
            f(id, self.node(id));
        }
    }

    /// The nodes reachable from `root` without passing through a node `done` accepts,
    /// children before parents: a memoised pass over a growing expression costs what is new
    /// in it, not its whole size.
    pub fn reachable_unless(
        &self,
        root: ExprId<L>,
        done: impl Fn(ExprId<L>) -> bool,
    ) -> Vec<ExprId<L>> {
        let mut order = Vec::new();
        let mut seen: FastSet<ExprId<L>> = FastSet::default();
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            if done(id) || !seen.insert(id) {
                continue;
            }
            order.push(id);
            stack.extend(children(self.node(id)));
        }
        // Ids are created children first, so id order is a topological order.
        order.sort_unstable();
        order
    }

    /// The size of `root` written out as a tree, as the emitters print it: a DAG with much
    /// sharing (the derivatives of a product) can stand for a tree no one can print.
    pub fn written_size(&self, root: ExprId<L>) -> u64 {
        let mut size: FastMap<ExprId<L>, u64> = FastMap::default();
        self.visit_reachable(&[root], |id, node| {
            let s = children(node)
                .map(|c| size.get(&c).copied().unwrap_or(0))
                .fold(1u64, u64::saturating_add);
            size.insert(id, s);
        });
        size.get(&root).copied().unwrap_or(0)
    }

    /// Every leaf reachable from `root`, in id order.
    pub fn leaves(&self, root: ExprId<L>) -> Vec<L> {
        let mut out = Vec::new();
        self.visit_reachable(&[root], |_, node| {
            if let Node::Leaf(l) = node {
                out.push(l);
            }
        });
        out
    }

    /// `root` with leaves replaced by `f` (leaves for which `f` returns `None` stay).
    pub fn substitute(
        &mut self,
        root: ExprId<L>,
        f: &mut impl FnMut(&mut Pool<L>, L) -> Option<ExprId<L>>,
    ) -> ExprId<L> {
        self.rebuild(root, &mut |pool, _, node| match node {
            Node::Leaf(l) => f(pool, l),
            _ => None,
        })
    }

    /// `root` with every occurrence of the subexpression `from` replaced by `to`.
    pub fn replace(&mut self, root: ExprId<L>, from: ExprId<L>, to: ExprId<L>) -> ExprId<L> {
        self.rebuild(root, &mut |_, id, _| (id == from).then_some(to))
    }

    /// `root` rebuilt bottom-up: each original node is first offered to `f`, which may replace
    /// it (whatever became of its children) or leave it to be rebuilt from its new children.
    fn rebuild(
        &mut self,
        root: ExprId<L>,
        f: &mut impl FnMut(&mut Pool<L>, ExprId<L>, Node<L>) -> Option<ExprId<L>>,
    ) -> ExprId<L> {
        let mut order = Vec::new();
        self.visit_reachable(&[root], |id, _| order.push(id));
        let mut map: FastMap<ExprId<L>, ExprId<L>> =
            FastMap::with_capacity_and_hasher(order.len(), Default::default());
        for id in order {
            if let Some(new) = f(self, id, self.node(id)) {
                map.insert(id, new);
                continue;
            }
            let m = |x: ExprId<L>| map.get(&x).copied().unwrap_or(x);
            let new = match self.node(id) {
                Node::Num(_) | Node::Leaf(_) => id,
                Node::Neg(a) => {
                    let a = m(a);
                    self.neg(a)
                }
                Node::Binary(op, a, b) => {
                    let (a, b) = (m(a), m(b));
                    self.binary(op, a, b)
                }
                Node::Call1(func, a) => {
                    let a = m(a);
                    self.call(func, &[a])
                }
                Node::Call2(func, a, b) => {
                    let (a, b) = (m(a), m(b));
                    self.call(func, &[a, b])
                }
                Node::Int(a) => {
                    let a = m(a);
                    self.int(a)
                }
            };
            map.insert(id, new);
        }
        map.get(&root).copied().unwrap_or(root)
    }
}

impl<L: LeafKind> Pool<L> {
    /// Copies `root` of `other` into this pool, mapping its leaves with `leaf`.
    pub fn import(
        &mut self,
        other: &Pool<L>,
        root: ExprId<L>,
        leaf: &mut impl FnMut(&mut Pool<L>, L) -> ExprId<L>,
    ) -> ExprId<L> {
        let mapped: Result<_, std::convert::Infallible> =
            self.try_import(other, root, &mut |p, l| Ok(leaf(p, l)));
        match mapped {
            Ok(id) => id,
            Err(never) => match never {},
        }
    }

    /// Copies `root` of a pool with other leaves into this one, mapping each leaf with `leaf`.
    pub fn import_from<M: LeafKind>(
        &mut self,
        other: &Pool<M>,
        root: ExprId<M>,
        mut leaf: impl FnMut(&mut Pool<L>, M) -> ExprId<L>,
    ) -> ExprId<L> {
        let mapped: Result<_, std::convert::Infallible> =
            self.try_import(other, root, &mut |p, l| Ok(leaf(p, l)));
        match mapped {
            Ok(id) => id,
            Err(never) => match never {},
        }
    }

    /// Copies `root` of a pool with other leaves into this one, mapping each leaf with
    /// `leaf`; the first leaf it refuses stops the copy with its error.
    pub fn try_import<M: LeafKind, E>(
        &mut self,
        other: &Pool<M>,
        root: ExprId<M>,
        leaf: &mut impl FnMut(&mut Pool<L>, M) -> Result<ExprId<L>, E>,
    ) -> Result<ExprId<L>, E> {
        let mut order = Vec::new();
        other.visit_reachable(&[root], |id, node| order.push((id, node)));
        let mut map: FastMap<ExprId<M>, ExprId<L>> =
            FastMap::with_capacity_and_hasher(order.len(), Default::default());
        for (id, node) in order {
            let m = |x: ExprId<M>| map[&x];
            let new = match node {
                Node::Num(bits) => self.num(f64::from_bits(bits)),
                Node::Leaf(l) => leaf(self, l)?,
                Node::Neg(a) => self.neg(m(a)),
                Node::Binary(op, a, b) => self.binary(op, m(a), m(b)),
                Node::Call1(f, a) => self.call(f, &[m(a)]),
                Node::Call2(f, a, b) => self.call(f, &[m(a), m(b)]),
                Node::Int(a) => self.int(m(a)),
            };
            map.insert(id, new);
        }
        Ok(map[&root])
    }
}

/// The children of a node.
pub fn children<L: LeafKind>(node: Node<L>) -> impl Iterator<Item = ExprId<L>> {
    let (a, b) = match node {
        Node::Num(_) | Node::Leaf(_) => (None, None),
        Node::Neg(a) | Node::Call1(_, a) | Node::Int(a) => (Some(a), None),
        Node::Binary(_, a, b) | Node::Call2(_, a, b) => (Some(a), Some(b)),
    };
    a.into_iter().chain(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_subexpressions_are_one_node() {
        let mut p = Pool::default();
        let x = p.leaf(Leaf::Time);
        let two = p.num(2.0);
        let a = p.mul(two, x);
        let b = p.mul(two, x);
        assert_eq!(a, b);
        let s = p.add(a, b);
        assert_eq!(p.len(), 4, "t, 2, 2*t and their sum");
        assert!(matches!(p.node(s), Node::Binary(BinOp::Add, l, r) if l == r));
    }

    #[test]
    fn constructors_fold_constants_and_neutral_elements() {
        let mut p = Pool::default();
        let x = p.leaf(Leaf::Time);
        let (zero, one, three) = (p.num(0.0), p.num(1.0), p.num(3.0));
        assert_eq!(p.add(x, zero), x);
        assert_eq!(p.mul(one, x), x);
        assert_eq!(p.mul(x, zero), zero);
        let nine = p.mul(three, three);
        assert_eq!(p.as_num(nine), Some(9.0));
        let nx = p.neg(x);
        assert_eq!(p.neg(nx), x);
        assert_eq!(p.sub(x, x), zero);
        let e = p.call(Func::Exp, &[zero]);
        assert_eq!(p.as_num(e), Some(1.0));
    }
}
