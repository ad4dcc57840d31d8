//! What a written form costs: the symbols a reader has to read.

use egg::{CostFunction, Id, Language, RecExpr};

use super::language::Math;
use super::rules::Graph;
use crate::expr::BinOp;
use crate::symbolic::hash::FastSet;

/// The cost of a written form, compared field by field.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub(super) struct Cost {
    /// Atoms, numbers, signs, operators, calls and pairs of parentheses, once each.
    pub length: usize,
    /// Products whose left operand is in parentheses: `a * (b + c)` reads better than
    /// `(b + c) * a`, so of two forms equally long the one with fewer is kept.
    disorder: usize,
    /// Nodes the canonical form does not have: of two forms equally long, the one closer
    /// to the canonical order is kept.
    novelty: usize,
    /// Binding strength of the top, as the printer sees it (it decides whether a parent
    /// puts this form in parentheses).
    binds: u8,
    /// Whether the top is a quotient.
    quotient: bool,
}

/// Counts what the printer will write, so that `a * b + a * c` → `a * (b + c)` saves one
/// symbol and `a + -(b)` costs more than `a - b`. A fraction that a product or quotient
/// continues (`a / b * c`) is counted as if it were in parentheses, since that is how it
/// has to be read. Lengths saturate, so the tree of a large DAG still compares.
pub(super) struct Readable {
    original: FastSet<Math>,
}

impl Readable {
    /// A cost function that prefers, among forms of equal length, the nodes of `expr`
    /// (the canonical form) as they stand in `egraph`.
    pub(super) fn new(egraph: &Graph, expr: &RecExpr<Math>) -> Self {
        let mut classes = Vec::with_capacity(expr.len());
        let mut original = FastSet::default();
        for node in expr.iter() {
            let mut node = node.clone().map_children(|i| classes[usize::from(i)]);
            // `lookup` also rewrites the children to their current classes.
            let Some(class) = egraph.lookup(&mut node) else {
                break;
            };
            classes.push(class);
            original.insert(node);
        }
        Readable { original }
    }

    /// A cost function for which nothing is original: for costing the input itself.
    pub(super) fn plain() -> Self {
        Readable {
            original: FastSet::default(),
        }
    }
}

impl CostFunction<Math> for Readable {
    type Cost = Cost;

    fn cost<C: FnMut(Id) -> Cost>(&mut self, enode: &Math, mut costs: C) -> Cost {
        let mut novelty = usize::from(!self.original.contains(enode));
        let mut disorder = 0usize;
        // An operand's length, with parentheses when it binds below what its place needs;
        // a quotient continued by `*` or `/` is counted as if it had them.
        let mut operand = |id: Id, needs: u8, continued: bool| {
            let c = costs(id);
            novelty = novelty.saturating_add(c.novelty);
            disorder = disorder.saturating_add(c.disorder);
            let parenthesised = c.binds < needs;
            let length = c
                .length
                .saturating_add(usize::from(parenthesised || (continued && c.quotient)));
            (length, parenthesised)
        };
        let (length, binds) = match enode {
            Math::Num(c) if c.value() < 0.0 => (2, 3),
            Math::Num(_) | Math::Atom(_) => (1, 5),
            Math::Neg([a]) => (1 + operand(*a, 3, false).0, 3),
            Math::Binary(op, [a, b]) => {
                let (left, right) = op.operand_precedence();
                let continued = matches!(op, BinOp::Mul | BinOp::Div);
                let (a, parenthesised) = operand(*a, left, continued);
                let (b, _) = operand(*b, right, false);
                if *op == BinOp::Mul && parenthesised {
                    disorder = disorder.saturating_add(1);
                }
                (a.saturating_add(b).saturating_add(1), op.precedence())
            }
            Math::Call1(_, [a]) => (1 + operand(*a, 0, false).0, 5),
            Math::Call2(_, [a, b]) => {
                let args = operand(*a, 0, false)
                    .0
                    .saturating_add(operand(*b, 0, false).0);
                (args.saturating_add(1), 5)
            }
        };
        Cost {
            length,
            disorder,
            novelty,
            binds,
            quotient: matches!(enode, Math::Binary(BinOp::Div, _)),
        }
    }
}
