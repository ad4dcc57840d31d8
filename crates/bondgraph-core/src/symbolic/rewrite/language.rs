//! The e-graph's language: the nodes of the expression DAG, and the moves between the two.

use std::fmt;
use std::str::FromStr;

use egg::{FromOp, Id, Language, RecExpr};

use crate::expr::{BinOp, Func};
use crate::symbolic::hash::FastMap;
use crate::symbolic::pool::{ExprId, Node, Pool};

/// A number in the e-graph, by its bits, ordered by value so that e-nodes sort stably.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) struct Constant(u64);

impl Constant {
    /// The constant `x` (with one zero).
    pub(super) fn new(x: f64) -> Self {
        Constant(if x == 0.0 { 0.0f64 } else { x }.to_bits())
    }

    /// Its value.
    pub(super) fn value(self) -> f64 {
        f64::from_bits(self.0)
    }
}

impl Ord for Constant {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.value().total_cmp(&other.value())
    }
}

impl PartialOrd for Constant {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// One e-node. Leaves and integrals are atoms: the rules never look inside them, so an
/// `int(..)` keeps the identity its running value is recorded under.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) enum Math {
    /// A number.
    Num(Constant),
    /// A leaf or an integral of the source expression, by its index in [`Atoms`].
    Atom(u32),
    /// `-a`
    Neg([Id; 1]),
    /// `a op b`
    Binary(BinOp, [Id; 2]),
    /// `f(a)`
    Call1(Func, [Id; 1]),
    /// `f(a, b)`
    Call2(Func, [Id; 2]),
}

/// What two e-nodes must share to match, children aside.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) enum Operator {
    /// A given number.
    Num(Constant),
    /// A given atom.
    Atom(u32),
    /// Negation.
    Neg,
    /// A binary operator.
    Binary(BinOp),
    /// A function.
    Call(Func),
}

impl Language for Math {
    type Discriminant = Operator;

    fn discriminant(&self) -> Operator {
        match *self {
            Math::Num(c) => Operator::Num(c),
            Math::Atom(a) => Operator::Atom(a),
            Math::Neg(_) => Operator::Neg,
            Math::Binary(op, _) => Operator::Binary(op),
            Math::Call1(f, _) | Math::Call2(f, _) => Operator::Call(f),
        }
    }

    fn matches(&self, other: &Self) -> bool {
        self.discriminant() == other.discriminant()
    }

    fn children(&self) -> &[Id] {
        match self {
            Math::Num(_) | Math::Atom(_) => &[],
            Math::Neg(c) | Math::Call1(_, c) => c,
            Math::Binary(_, c) | Math::Call2(_, c) => c,
        }
    }

    fn children_mut(&mut self) -> &mut [Id] {
        match self {
            Math::Num(_) | Math::Atom(_) => &mut [],
            Math::Neg(c) | Math::Call1(_, c) => c,
            Math::Binary(_, c) | Math::Call2(_, c) => c,
        }
    }
}

impl fmt::Display for Math {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Math::Num(c) => write!(f, "{}", c.value()),
            Math::Atom(a) => write!(f, "atom{a}"),
            Math::Neg(_) => f.write_str("neg"),
            Math::Binary(op, _) => f.write_str(op.symbol()),
            Math::Call1(func, _) | Math::Call2(func, _) => f.write_str(func.name()),
        }
    }
}

/// Why an operator of a rule could not be read.
#[derive(Debug)]
pub(super) struct UnknownOperator(String);

impl fmt::Display for UnknownOperator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "no operator `{}` in the rules' language", self.0)
    }
}

impl FromOp for Math {
    type Error = UnknownOperator;

    fn from_op(op: &str, children: Vec<Id>) -> Result<Self, UnknownOperator> {
        let node = match (
            children.as_slice(),
            BinOp::from_symbol(op),
            Func::from_name(op),
        ) {
            ([], ..) => match (f64::from_str(op), op.strip_prefix("atom")) {
                (Ok(x), _) => Some(Math::Num(Constant::new(x))),
                (_, Some(n)) => n.parse().ok().map(Math::Atom),
                _ => None,
            },
            (&[a], ..) if op == "neg" => Some(Math::Neg([a])),
            (&[a, b], Some(bin), _) => Some(Math::Binary(bin, [a, b])),
            (&[a], _, Some(f)) if f.arity() == 1 => Some(Math::Call1(f, [a])),
            (&[a, b], _, Some(f)) if f.arity() == 2 => Some(Math::Call2(f, [a, b])),
            _ => None,
        };
        node.ok_or_else(|| UnknownOperator(format!("{op}/{}", children.len())))
    }
}

/// The atoms of one expression: what `Math::Atom(i)` stands for.
pub(super) struct Atoms(Vec<ExprId>);

/// `root` as an e-graph expression, shared nodes still shared, with its atoms.
pub(super) fn to_egg(pool: &Pool, root: ExprId) -> (RecExpr<Math>, Atoms) {
    let mut expr = RecExpr::default();
    let mut atoms = Vec::new();
    let mut ids: FastMap<ExprId, Id> = FastMap::default();
    // Children of an integral are never visited: it is an atom.
    let order = pool.reachable_unless(root, |_| false);
    for id in order {
        if ids.contains_key(&id) {
            continue;
        }
        let child = |x: ExprId| ids.get(&x).copied();
        let node = match pool.node(id) {
            Node::Num(bits) => Some(Math::Num(Constant::new(f64::from_bits(bits)))),
            Node::Leaf(_) | Node::Int(_) => None,
            Node::Neg(a) => child(a).map(|a| Math::Neg([a])),
            Node::Binary(op, a, b) => child(a)
                .zip(child(b))
                .map(|(a, b)| Math::Binary(op, [a, b])),
            Node::Call1(f, a) => child(a).map(|a| Math::Call1(f, [a])),
            Node::Call2(f, a, b) => child(a).zip(child(b)).map(|(a, b)| Math::Call2(f, [a, b])),
        };
        let node = node.unwrap_or_else(|| {
            atoms.push(id);
            Math::Atom(atoms.len() as u32 - 1)
        });
        ids.insert(id, expr.add(node));
    }
    (expr, Atoms(atoms))
}

/// An e-graph expression back in `pool`, through its constructors (which fold what the
/// rules left foldable, and write `a + -b` as `a - b`).
pub(super) fn from_egg(pool: &mut Pool, expr: &RecExpr<Math>, atoms: &Atoms) -> ExprId {
    let mut ids: Vec<ExprId> = Vec::with_capacity(expr.len());
    for node in expr.iter() {
        let at = |i: &Id| ids[usize::from(*i)];
        let id = match node {
            Math::Num(c) => pool.num(c.value()),
            Math::Atom(a) => atoms.0[*a as usize],
            Math::Neg([a]) => pool.neg(at(a)),
            Math::Binary(op, [a, b]) => pool.binary(*op, at(a), at(b)),
            Math::Call1(f, [a]) => pool.call(*f, &[at(a)]),
            Math::Call2(f, [a, b]) => pool.call(*f, &[at(a), at(b)]),
        };
        ids.push(id);
    }
    ids.last().copied().unwrap_or_else(|| pool.num(0.0))
}
