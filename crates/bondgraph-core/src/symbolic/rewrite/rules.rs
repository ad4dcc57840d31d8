//! The rewrite rules and the constant-folding analysis.
//!
//! Every rule is an identity of real arithmetic wherever both sides are defined; none
//! cancels a factor (`x / x = 1` would hide a division by zero the canonical form shows).
//! The canonical form arrives expanded, so the rules mostly regroup: they reorder, factor
//! out common factors and common denominators, and collect like terms.

use egg::{merge_option, rewrite, Analysis, DidMerge, EGraph, Id, Rewrite};

use super::language::{Constant, Math};

/// The e-graph of one expression.
pub(super) type Graph = EGraph<Math, ConstantFold>;

/// Folds operations on numbers into numbers, so that `2 a + 3 a` becomes `5 a`.
#[derive(Default, Clone, Copy, Debug)]
pub(super) struct ConstantFold;

impl Analysis<Math> for ConstantFold {
    type Data = Option<Constant>;

    fn make(egraph: &mut Graph, enode: &Math, _id: Id) -> Option<Constant> {
        let x = |i: &Id| egraph[*i].data.map(Constant::value);
        let value = match enode {
            Math::Num(c) => c.value(),
            Math::Atom(_) => return None,
            Math::Neg([a]) => -x(a)?,
            Math::Binary(op, [a, b]) => op.apply(x(a)?, x(b)?),
            Math::Call1(f, [a]) => f.apply(&[x(a)?]),
            Math::Call2(f, [a, b]) => f.apply(&[x(a)?, x(b)?]),
        };
        // A division by zero or a log of a negative stays written out.
        value.is_finite().then(|| Constant::new(value))
    }

    fn merge(&mut self, to: &mut Option<Constant>, from: Option<Constant>) -> DidMerge {
        // Two routes to one constant may round differently; the first one found stays.
        merge_option(to, from, |_, _| DidMerge(false, true))
    }

    fn modify(egraph: &mut Graph, id: Id) {
        if let Some(c) = egraph[id].data {
            let num = egraph.add(Math::Num(c));
            egraph.union(id, num);
            // `-4` is also `-(4)`, so that `a + -4 b` can become `a - 4 b`.
            if c.value() < 0.0 {
                let magnitude = egraph.add(Math::Num(Constant::new(-c.value())));
                let negated = egraph.add(Math::Neg([magnitude]));
                egraph.union(id, negated);
            }
        }
    }
}

/// The rules, in a fixed order (the order is part of what makes the result deterministic).
pub(super) fn rules() -> Vec<Rewrite<Math, ConstantFold>> {
    let mut rules = vec![
        rewrite!("add-commute"; "(+ ?a ?b)" => "(+ ?b ?a)"),
        rewrite!("mul-commute"; "(* ?a ?b)" => "(* ?b ?a)"),
        rewrite!("neg-neg"; "(neg (neg ?a))" => "?a"),
        rewrite!("sub-swap"; "(- ?a ?b)" => "(neg (- ?b ?a))"),
        rewrite!("factor"; "(+ (* ?a ?b) (* ?a ?c))" => "(* ?a (+ ?b ?c))"),
        rewrite!("factor-one"; "(+ ?a (* ?a ?c))" => "(* ?a (+ 1 ?c))"),
        rewrite!("collect"; "(+ ?a ?a)" => "(* 2 ?a)"),
        rewrite!("common-denominator"; "(+ (/ ?a ?c) (/ ?b ?c))" => "(/ (+ ?a ?b) ?c)"),
        // Exact at zero too: odd laws read the other way (`sign(f)*(abs(f)/c)^2`) leave
        // these in their derivatives.
        rewrite!("sign-abs"; "(* (sign ?a) (abs ?a))" => "?a"),
        rewrite!("abs-sign-squared"; "(* (abs ?a) (^ (sign ?a) 2))" => "(abs ?a)"),
    ];
    for pair in [
        rewrite!("add-associate"; "(+ ?a (+ ?b ?c))" <=> "(+ (+ ?a ?b) ?c)"),
        rewrite!("mul-associate"; "(* ?a (* ?b ?c))" <=> "(* (* ?a ?b) ?c)"),
        rewrite!("sub-as-add"; "(- ?a ?b)" <=> "(+ ?a (neg ?b))"),
        rewrite!("neg-add"; "(neg (+ ?a ?b))" <=> "(+ (neg ?a) (neg ?b))"),
        rewrite!("neg-mul"; "(neg (* ?a ?b))" <=> "(* (neg ?a) ?b)"),
        rewrite!("neg-div"; "(neg (/ ?a ?b))" <=> "(/ (neg ?a) ?b)"),
        rewrite!("mul-div"; "(* ?a (/ ?b ?c))" <=> "(/ (* ?a ?b) ?c)"),
        rewrite!("div-div"; "(/ (/ ?a ?b) ?c)" <=> "(/ ?a (* ?b ?c))"),
    ] {
        rules.extend(pair);
    }
    rules
}
