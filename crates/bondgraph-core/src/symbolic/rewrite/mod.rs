//! Simplification by equality saturation (egg): the cheapest readable way to write an
//! expression.
//!
//! The pipeline computes with canonical forms ([`super::Simplifier`]): expanded sums of
//! products in a fixed order, which make equal expressions equal nodes. They are not how
//! a person writes an equation, so before an expression is shown it goes through an
//! e-graph: `rules` regroups it (factors, common denominators, like terms, constants),
//! and the cost function of `cost` picks the form with the fewest symbols. The search stops at
//! explicit limits, all of them counts (e-nodes, iterations, rounds, a budget for the
//! model), never seconds: the same model gets the same forms on every machine and under any
//! load. Its result is used only when it is strictly cheaper than the canonical form.

mod cost;
mod language;
mod rules;

use std::cell::RefCell;
use std::collections::HashMap;

use egg::{CostFunction, Extractor, RecExpr, Rewrite, Runner, StopReason};

use super::pool::{ExprId, Pool};
use cost::Readable;
use language::{from_egg, to_egg, Math};
use rules::ConstantFold;

/// How far the search may go for one expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// E-nodes in the e-graph; also the largest expression (in DAG nodes) that is tried.
    pub nodes: usize,
    /// Rounds of rule application in one e-graph.
    pub iterations: usize,
    /// E-graphs grown one after the other, each from the best form of the one before.
    pub rounds: usize,
    /// E-nodes for all the expressions of one model together, so that a model of thousands
    /// of expressions is written in bounded time; later expressions are shown as they are.
    pub budget: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            nodes: 5_000,
            iterations: 30,
            rounds: 4,
            budget: 2_000_000,
        }
    }
}

/// How the search for one expression ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// No rule had anything left to add: the cheapest form was found.
    Saturated,
    /// The node limit was reached.
    NodeLimit,
    /// The iteration limit was reached.
    IterationLimit,
    /// The expression alone exceeds the node limit; it was not tried.
    TooLarge,
    /// Earlier expressions of the model spent the e-node budget; it was not tried.
    Budget,
}

/// The written form chosen for one expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rewritten {
    /// The expression to show: the cheapest found, or the input if nothing was cheaper.
    pub expr: ExprId,
    /// Printed length of the input: atoms, numbers, signs, operators, calls, parentheses.
    pub before: usize,
    /// Length of `expr`.
    pub after: usize,
    /// How the search ended.
    pub stop: Stop,
    /// E-nodes built, over all rounds.
    pub nodes: usize,
}

/// Chooses written forms under fixed limits, with its rules parsed once.
pub(crate) struct Rewriter {
    rules: Vec<Rewrite<Math, ConstantFold>>,
    limits: Limits,
    /// Rounds already run, by their input: the search depends on the e-graph expression
    /// alone (atoms are numbered in the order they are met), so an expression of the same
    /// shape as one seen before (the ARRs of the stages of a chain) gets the same form at
    /// no cost.
    seen: RefCell<HashMap<RecExpr<Math>, Seen>>,
}

/// What a round gave: its best form when shorter than its input, how it stopped, its size.
#[derive(Clone)]
struct Seen {
    best: Option<RecExpr<Math>>,
    stop: Stop,
    nodes: usize,
}

impl Rewriter {
    /// A rewriter with the given limits.
    pub(crate) fn new(limits: Limits) -> Self {
        // The budget is spent by whoever runs many expressions (`Analysis::simplify`).
        Rewriter {
            rules: rules::rules(),
            limits,
            seen: RefCell::new(HashMap::new()),
        }
    }

    /// The cheapest form of `root` found within the limits, built in `pool`.
    ///
    /// The search runs in rounds: each starts a fresh e-graph from the previous round's best
    /// form, so a node limit that stops one round early (commutativity and associativity fill
    /// it fast) does not stop the regrouping. Rounds end when one saturates or gains nothing.
    pub(crate) fn cheapest(&self, pool: &mut Pool, root: ExprId) -> Rewritten {
        let before = length(pool, root);
        let mut best = root;
        let mut stop = Stop::Saturated;
        let mut nodes = 0usize;
        for _ in 0..self.limits.rounds.max(1) {
            let round = self.round(pool, best);
            stop = round.stop;
            nodes = nodes.saturating_add(round.nodes);
            let improved = round.expr != best;
            best = round.expr;
            if !improved || stop == Stop::Saturated {
                break;
            }
        }
        let after = length(pool, best);
        if after >= before {
            best = root;
        }
        Rewritten {
            expr: best,
            before,
            after: after.min(before),
            stop,
            nodes,
        }
    }

    /// One e-graph: `root` and what the rules reach from it within the limits, and its
    /// shortest form if that is shorter than `root`.
    fn round(&self, pool: &mut Pool, root: ExprId) -> Round {
        let (expr, atoms) = to_egg(pool, root);
        if expr.len() > self.limits.nodes {
            return Round::unchanged(root, Stop::TooLarge, 0);
        }
        if let Some(seen) = self.seen.borrow().get(&expr) {
            // Free: nothing was built.
            return Round {
                expr: seen
                    .best
                    .as_ref()
                    .map_or(root, |best| from_egg(pool, best, &atoms)),
                stop: seen.stop,
                nodes: 0,
            };
        }
        let seen = self.search(&expr);
        self.seen.borrow_mut().insert(expr, seen.clone());
        Round {
            expr: seen
                .best
                .as_ref()
                .map_or(root, |best| from_egg(pool, best, &atoms)),
            stop: seen.stop,
            nodes: seen.nodes,
        }
    }

    /// The e-graph of `expr` within the limits, and its shortest form if shorter.
    fn search(&self, expr: &RecExpr<Math>) -> Seen {
        let runner = Runner::<Math, ConstantFold, ()>::default()
            .with_node_limit(self.limits.nodes)
            .with_iter_limit(self.limits.iterations)
            // egg stops at 5 s by default: a search stopped by the clock would make the
            // output depend on the machine's speed and load. The node limit is checked after
            // each rule's matches are applied, and egg's scheduler bans a rule whose matches
            // explode, so the counts bound the work.
            .with_time_limit(std::time::Duration::MAX)
            .with_expr(expr)
            .run(&self.rules);
        let stop = match runner.stop_reason {
            Some(StopReason::NodeLimit(_)) => Stop::NodeLimit,
            Some(StopReason::IterationLimit(_)) => Stop::IterationLimit,
            _ => Stop::Saturated,
        };
        let nodes = runner.egraph.total_number_of_nodes();
        let unchanged = Seen {
            best: None,
            stop,
            nodes,
        };
        let Some(&top) = runner.roots.first() else {
            return unchanged;
        };
        let readable = Readable::new(&runner.egraph, expr);
        let (cost, best) = Extractor::new(&runner.egraph, readable).find_best(top);
        if cost.length >= Readable::plain().cost_rec(expr).length {
            return unchanged;
        }
        Seen {
            best: Some(best),
            ..unchanged
        }
    }
}

/// What one round of [`Rewriter::cheapest`] gives.
struct Round {
    expr: ExprId,
    stop: Stop,
    nodes: usize,
}

impl Round {
    fn unchanged(expr: ExprId, stop: Stop, nodes: usize) -> Self {
        Round { expr, stop, nodes }
    }
}

/// The printed length of `root`.
pub(crate) fn length(pool: &Pool, root: ExprId) -> usize {
    Readable::plain().cost_rec(&to_egg(pool, root).0).length
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::{BinOp, Func};
    use crate::graph::ParamId;
    use crate::symbolic::{Evaluator, Leaf, Printer, Simplifier};

    /// Reads `(op arg..)` with one-letter parameters, so that tests read like the rules.
    fn parse(pool: &mut Pool, text: &str) -> ExprId {
        let spaced = text.replace('(', " ( ").replace(')', " ) ");
        let tokens: Vec<&str> = spaced.split_whitespace().collect();
        let (e, rest) = read(pool, &tokens);
        assert!(rest.is_empty(), "trailing tokens in `{text}`");
        e
    }

    fn read<'t>(pool: &mut Pool, tokens: &'t [&'t str]) -> (ExprId, &'t [&'t str]) {
        match tokens {
            ["(", op, rest @ ..] => {
                let (mut args, mut rest) = (Vec::new(), rest);
                while rest.first() != Some(&")") {
                    let (arg, after) = read(pool, rest);
                    args.push(arg);
                    rest = after;
                }
                (build(pool, op, &args), &rest[1..])
            }
            [word, rest @ ..] => {
                let e = match word.parse::<f64>() {
                    Ok(x) => pool.num(x),
                    Err(_) => pool.leaf(Leaf::Param(ParamId(u32::from(word.as_bytes()[0] - b'a')))),
                };
                (e, rest)
            }
            [] => panic!("unbalanced test expression"),
        }
    }

    fn build(pool: &mut Pool, op: &str, args: &[ExprId]) -> ExprId {
        match (op, args, BinOp::from_symbol(op)) {
            ("neg", &[a], _) => pool.neg(a),
            ("int", &[a], _) => pool.int(a),
            (_, &[a, b], Some(bin)) => pool.binary(bin, a, b),
            (f, args, _) => pool.call(Func::from_name(f).unwrap_or(Func::Exp), args),
        }
    }

    fn text(pool: &Pool, e: ExprId) -> String {
        Printer::new(pool, |l| match l {
            Leaf::Param(p) => char::from(b'a' + p.0 as u8).to_string(),
            other => format!("{other:?}"),
        })
        .text(e)
    }

    /// The written form `rewriter` chooses for the canonical form of `source`.
    fn written(source: &str) -> String {
        let mut pool = Pool::default();
        let e = parse(&mut pool, source);
        let canonical = Simplifier::default().simplify(&mut pool, e);
        let r = Rewriter::new(Limits::default()).cheapest(&mut pool, canonical);
        text(&pool, r.expr)
    }

    #[test]
    fn common_factors_and_denominators_are_taken_out() {
        assert_eq!(written("(+ (* a b) (* a c))"), "a * (b + c)");
        assert_eq!(written("(+ (/ a d) (/ b d))"), "(a + b) / d");
        assert_eq!(
            written("(- (* a (* b c)) (* a (* b d)))"),
            "a * b * (c - d)"
        );
    }

    #[test]
    fn like_terms_are_collected_and_signs_read_as_subtraction() {
        assert_eq!(written("(+ (* 2 (* a b)) (* 3 (* b a)))"), "5 * a * b");
        assert_eq!(written("(+ a (* -4 b))"), "a - 4 * b");
    }

    #[test]
    fn what_cannot_be_shortened_stays_canonical() {
        for source in [
            "(- a b)",
            "(+ (* a b) (* c d))",
            "(/ a (* b c))",
            "(sin (+ a b))",
        ] {
            let mut pool = Pool::default();
            let e = parse(&mut pool, source);
            let canonical = Simplifier::default().simplify(&mut pool, e);
            let r = Rewriter::new(Limits::default()).cheapest(&mut pool, canonical);
            assert_eq!(r.expr, canonical, "{source}");
            assert_eq!(r.before, r.after);
        }
    }

    #[test]
    fn integrals_are_atoms() {
        let mut pool = Pool::default();
        let inner = parse(&mut pool, "(+ (* a b) (* a c))");
        let whole = parse(
            &mut pool,
            "(+ (* d (int (+ (* a b) (* a c)))) (* e (int (+ (* a b) (* a c)))))",
        );
        let r = Rewriter::new(Limits::default()).cheapest(&mut pool, whole);
        let int = pool.int(inner);
        assert_eq!(
            text(&pool, r.expr),
            format!("{} * (d + e)", text(&pool, int))
        );
        // The very node, so that its recorded running value still applies.
        let mut kept = false;
        pool.visit_reachable(&[r.expr], |id, _| kept |= id == int);
        assert!(kept);
    }

    #[test]
    fn limits_are_kept_and_are_counts_only() {
        let source = "(+ (* a (* b c)) (+ (* a (* b d)) (+ (* a (* c d)) (* b (* c d)))))";
        let mut pool = Pool::default();
        let e = parse(&mut pool, source);
        let tight = |nodes, iterations| Limits {
            nodes,
            iterations,
            ..Limits::default()
        };
        let r = Rewriter::new(tight(3, 30)).cheapest(&mut pool, e);
        assert_eq!((r.stop, r.expr), (Stop::TooLarge, e));
        let r = Rewriter::new(tight(5_000, 1)).cheapest(&mut pool, e);
        assert_eq!(r.stop, Stop::IterationLimit);
        // The same search twice, in fresh rewriters, builds the same e-graph: nothing but
        // the counts decides where it stops.
        let once = Rewriter::new(tight(200, 30)).cheapest(&mut pool, e);
        let again = Rewriter::new(tight(200, 30)).cheapest(&mut pool, e);
        assert!(once.nodes > 200, "a round stopped at the node limit");
        assert_eq!(once, again);
    }

    /// A small deterministic generator, so the property test is the same on every run.
    struct Lcg(u64);

    impl Lcg {
        fn below(&mut self, n: u64) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) % n
        }
    }

    fn random_expr(pool: &mut Pool, rng: &mut Lcg, depth: u32) -> ExprId {
        if depth == 0 || rng.below(4) == 0 {
            return match rng.below(6) {
                0 => pool.num((rng.below(7) as f64) - 3.0),
                k => pool.leaf(Leaf::Param(ParamId(k as u32 - 1))),
            };
        }
        let a = random_expr(pool, rng, depth - 1);
        let b = random_expr(pool, rng, depth - 1);
        match rng.below(7) {
            0 | 1 => pool.add(a, b),
            2 => pool.sub(a, b),
            3 | 4 => pool.mul(a, b),
            5 => pool.div(a, b),
            _ => pool.call(Func::Sin, &[a]),
        }
    }

    #[test]
    fn rewritten_forms_are_never_longer_and_equal_the_canonical_ones_everywhere() {
        let mut rng = Lcg(7);
        let mut shortened = 0;
        for _ in 0..60 {
            let mut pool = Pool::default();
            let e = random_expr(&mut pool, &mut rng, 5);
            let canonical = Simplifier::default().simplify(&mut pool, e);
            let r = Rewriter::new(Limits::default()).cheapest(&mut pool, canonical);
            assert!(r.after <= r.before);
            shortened += usize::from(r.after < r.before);
            for _ in 0..5 {
                let point: Vec<f64> = (0..5)
                    .map(|_| 0.5 + rng.below(1000) as f64 / 700.0)
                    .collect();
                let value = |root| {
                    Evaluator::new(&pool, |l| match l {
                        Leaf::Param(p) => point[p.index()],
                        _ => f64::NAN,
                    })
                    .value(root)
                };
                let (want, got) = (value(canonical), value(r.expr));
                if want.is_finite() && want.abs() < 1e6 {
                    let tolerance = 1e-9 * want.abs().max(1.0);
                    assert!(
                        (want - got).abs() <= tolerance,
                        "{} = {want} but {} = {got}",
                        text(&pool, canonical),
                        text(&pool, r.expr)
                    );
                }
            }
        }
        assert!(shortened > 10, "only {shortened} of 60 were shortened");
    }

    #[test]
    fn the_same_expression_is_written_the_same_way_every_time() {
        let source = "(+ (* a (* b c)) (+ (* a (* b d)) (+ (/ (* a c) e) (/ (* b d) e))))";
        let first = written(source);
        for _ in 0..3 {
            assert_eq!(written(source), first);
        }
    }
}
