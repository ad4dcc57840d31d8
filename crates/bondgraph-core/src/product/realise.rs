//! How each ARR is realised on sampled signals: as written, or by integration, with one order
//! of differentiation fewer.
//!
//! A relation whose derivatives enter linearly with constant coefficients (parameters and
//! numbers), `r = A + Σ cₖ·y⁽ⁿᵏ⁾`, where `A` reads no derivative, is the time derivative of
//! `F = Σ cₖ·y⁽ⁿᵏ⁻¹⁾` plus `A`. Its integral from a reference instant,
//! `F(t) − F(t₀) + ∫_{t₀}^t A dt`, vanishes exactly when `r` does on `[t₀, t]`, and reads each
//! derivative one order lower: a first derivative instead of a second, a signal instead of a
//! first derivative. On noisy samples that is the difference that counts: the noise gain of a
//! derivative estimate grows by the window's length for each order. `A`'s nonlinear terms
//! (the bench's backlash `w'(z)·ż`) are integrated numerically: a fault of a modulation that
//! shows only while its argument moves stays visible as long as the reference instant is
//! before that motion (the window, or the whole record from the start).

use std::collections::HashMap;

use super::build::reads;
use super::{Arr, Compiled, Expr, Exprs, Integrated, Realisation, ResidualForm, Symbol};
use crate::expr::BinOp;
use crate::symbolic::{Derivatives, Node};

/// `r = rate + d(level)/dt`, each part absent when zero.
#[derive(Clone, Copy, Default)]
struct Split {
    level: Option<Expr>,
    rate: Option<Expr>,
}

/// What is known of a node: the highest derivative order it reads, whether it is a constant,
/// whether it reads a signal's value other than under an integral.
#[derive(Clone, Copy)]
struct Facts {
    order: u32,
    constant: bool,
    pointwise: bool,
}

impl Facts {
    /// Varies only through integrals of signals, and time: its own rate reads no derivative.
    fn slow(self) -> bool {
        self.order == 0 && !self.pointwise
    }
}

/// Realises every ARR of `c` that reads a derivative and can be integrated that way; the
/// others, and simulated residuals, stay direct. An integrated ARR has no adaptive
/// threshold (its sensitivities are those of the relation, read at orders it no longer
/// estimates).
pub(crate) fn realise(c: &mut Compiled) {
    for k in 0..c.arrs.len() {
        if let Some(integrated) = integrated(&mut c.exprs, &c.arrs[k]) {
            let arr = &mut c.arrs[k];
            let (reads, integrals) = reads(&c.exprs, &c.auxiliaries, &c.roots, integrated.0);
            arr.realisation = Realisation::Integrated(Integrated {
                level: integrated.1,
                rate: integrated.2,
                expr: integrated.0,
                reads,
                integrals,
            });
            arr.sensitivities = None;
        }
    }
}

/// `(level + int(rate), level, rate)` for `arr`, when it is worth realising that way.
fn integrated(exprs: &mut Exprs, arr: &Arr) -> Option<(Expr, Expr, Expr)> {
    let reads_derivative = arr.reads.iter().any(|r| r.orders.iter().any(|&n| n > 0));
    if arr.form != ResidualForm::Relation || !arr.auxiliaries.is_empty() || !reads_derivative {
        return None;
    }
    let split = split(exprs, arr.expr)?;
    let level = split.level?;
    let rate = split.rate.unwrap_or_else(|| exprs.num(0.0));
    let integral = integral(exprs, rate);
    Some((exprs.add(level, integral), level, rate))
}

/// `int(e)`, with each term `c·y` of a signal `y` as `c·int(y)`: a signal's integral is one
/// trapezoidal rule on its samples, shared by every ARR that reads it; the other terms stay
/// under one `int(..)`.
fn integral(exprs: &mut Exprs, e: Expr) -> Expr {
    let mut linear: Vec<(bool, Expr)> = Vec::new();
    let mut rest: Vec<(bool, Expr)> = Vec::new();
    let mut stack = vec![(true, e)];
    while let Some((plus, e)) = stack.pop() {
        match exprs.node(e) {
            Node::Binary(BinOp::Add, a, b) => stack.extend([(plus, b), (plus, a)]),
            Node::Binary(BinOp::Sub, a, b) => stack.extend([(!plus, b), (plus, a)]),
            Node::Neg(a) => stack.push((!plus, a)),
            _ => match scaled_signal(exprs, e) {
                Some((c, y)) => {
                    let iy = exprs.int(y);
                    let term = match c {
                        Some((BinOp::Div, c)) => exprs.div(iy, c),
                        Some((_, c)) => exprs.mul(c, iy),
                        None => iy,
                    };
                    linear.push((plus, term));
                }
                None => rest.push((plus, e)),
            },
        }
    }
    if !rest.is_empty() {
        let rest = exprs.signed_sum(&rest);
        let int = exprs.int(rest);
        linear.push((true, int));
    }
    exprs.signed_sum(&linear)
}

/// `e` as a signal (input or measured, not differentiated) times or over a constant.
fn scaled_signal(exprs: &Exprs, e: Expr) -> Option<(Option<(BinOp, Expr)>, Expr)> {
    let signal = |x: Expr| {
        matches!(
            exprs.node(x),
            Node::Leaf(Symbol::Input(_, 0) | Symbol::Sensor(_, 0))
        )
    };
    let constant = |x: Expr| {
        (exprs.leaves(x).iter()).all(|l| matches!(l, Symbol::Parameter(_)))
            && !exprs_has_int(exprs, x)
    };
    match exprs.node(e) {
        _ if signal(e) => Some((None, e)),
        Node::Binary(BinOp::Mul, c, y) if signal(y) && constant(c) => {
            Some((Some((BinOp::Mul, c)), y))
        }
        Node::Binary(BinOp::Mul, y, c) if signal(y) && constant(c) => {
            Some((Some((BinOp::Mul, c)), y))
        }
        Node::Binary(BinOp::Div, y, c) if signal(y) && constant(c) => {
            Some((Some((BinOp::Div, c)), y))
        }
        _ => None,
    }
}

fn exprs_has_int(exprs: &Exprs, e: Expr) -> bool {
    let mut found = false;
    exprs.visit_reachable(&[e], |_, n| found |= matches!(n, Node::Int(_)));
    found
}

/// `e` as `rate + d(level)/dt`, if its highest derivatives enter linearly, with constant
/// coefficients or, for first derivatives, coefficients that vary only through integrals and
/// time. What reads lower orders only and splits no further goes to the rate whole: a position
/// encoder's relation `m·x'' + Fc·sign(x') = F` integrates to `m·x' + ∫(Fc·sign(x') − F)`.
fn split(exprs: &mut Exprs, e: Expr) -> Option<Split> {
    let mut order: Vec<Expr> = Vec::new();
    exprs.visit_reachable(&[e], |id, _| order.push(id));
    let mut facts: HashMap<Expr, Facts> = HashMap::with_capacity(order.len());
    for &id in &order {
        let f = node_facts(exprs.node(id), &facts);
        facts.insert(id, f);
    }
    let top = facts.get(&e)?.order;
    let mut splits: HashMap<Expr, Option<Split>> = HashMap::new();
    let whole = |id: Expr| Split {
        level: None,
        rate: Some(id),
    };
    for id in order {
        let s = match facts[&id].order {
            0 => Some(whole(id)),
            n => split_node(exprs, exprs.node(id), top, &facts, &splits)
                .or_else(|| (n < top).then(|| whole(id))),
        };
        splits.insert(id, s);
    }
    splits.get(&e).copied().flatten()
}

fn node_facts(node: Node<Symbol>, facts: &HashMap<Expr, Facts>) -> Facts {
    let of = |a: Expr| {
        facts.get(&a).copied().unwrap_or(Facts {
            order: u32::MAX,
            constant: false,
            pointwise: true,
        })
    };
    let leaf = |order: u32, constant: bool, pointwise: bool| Facts {
        order,
        constant,
        pointwise,
    };
    match node {
        Node::Num(_) => leaf(0, true, false),
        Node::Leaf(l) => match l {
            Symbol::Parameter(_) => leaf(0, true, false),
            Symbol::Input(_, n)
            | Symbol::Sensor(_, n)
            | Symbol::Auxiliary(_, n)
            | Symbol::Root(_, n) => leaf(n, false, true),
            Symbol::Time => leaf(0, false, false),
            Symbol::State(_) | Symbol::Loop(_) => leaf(0, false, true),
        },
        Node::Int(a) => leaf(of(a).order, false, false),
        Node::Neg(a) | Node::Call1(_, a) => of(a),
        Node::Binary(_, a, b) | Node::Call2(_, a, b) => {
            let (a, b) = (of(a), of(b));
            Facts {
                order: a.order.max(b.order),
                constant: a.constant && b.constant,
                pointwise: a.pointwise || b.pointwise,
            }
        }
    }
}

/// The split of a node that reads a derivative, from its children's.
fn split_node(
    exprs: &mut Exprs,
    node: Node<Symbol>,
    top: u32,
    facts: &HashMap<Expr, Facts>,
    splits: &HashMap<Expr, Option<Split>>,
) -> Option<Split> {
    let constant = |a: Expr| facts.get(&a).is_some_and(|f| f.constant);
    let slow = |a: Expr| facts.get(&a).is_some_and(|f| f.slow());
    let of = |a: Expr| splits.get(&a).copied().flatten();
    match node {
        Node::Leaf(Symbol::Sensor(s, n)) if n > 0 => Some(Split {
            level: Some(exprs.leaf(Symbol::Sensor(s, n - 1))),
            rate: None,
        }),
        Node::Leaf(Symbol::Input(u, n)) if n > 0 => Some(Split {
            level: Some(exprs.leaf(Symbol::Input(u, n - 1))),
            rate: None,
        }),
        // A root's derivative integrates to the root, which the generator solves for.
        Node::Leaf(Symbol::Root(h, n)) if n > 0 => Some(Split {
            level: Some(exprs.leaf(Symbol::Root(h, n - 1))),
            rate: None,
        }),
        Node::Neg(a) => Some(map(exprs, of(a)?, |p, x| p.neg(x))),
        Node::Binary(BinOp::Add, a, b) => Some(combine(exprs, of(a)?, of(b)?, true)),
        Node::Binary(BinOp::Sub, a, b) => Some(combine(exprs, of(a)?, of(b)?, false)),
        Node::Binary(BinOp::Mul, a, b) if constant(a) => {
            Some(map(exprs, of(b)?, |p, x| p.mul(a, x)))
        }
        Node::Binary(BinOp::Mul, a, b) if constant(b) => {
            Some(map(exprs, of(a)?, |p, x| p.mul(x, b)))
        }
        Node::Binary(BinOp::Div, a, b) if constant(b) => {
            Some(map(exprs, of(a)?, |p, x| p.div(x, b)))
        }
        Node::Binary(BinOp::Mul, a, b) if slow(a) => product(exprs, a, of(b)?, top),
        Node::Binary(BinOp::Mul, a, b) if slow(b) => product(exprs, b, of(a)?, top),
        Node::Binary(BinOp::Div, a, b) if slow(b) => {
            let one = exprs.num(1.0);
            let inverse = exprs.div(one, b);
            product(exprs, inverse, of(a)?, top)
        }
        _ => None,
    }
}

/// `c·x` for `x = rate + d(level)/dt` and `c` a function of integrals and time, by the product
/// rule: `c·rate − (dc/dt)·level + d(c·level)/dt`, when `level` reads derivatives of orders
/// below `top - 1` only (else the new rate would read the order the split removes).
fn product(exprs: &mut Exprs, c: Expr, x: Split, top: u32) -> Option<Split> {
    let Some(level) = x.level else {
        return Some(map(exprs, x, |p, y| p.mul(c, y)));
    };
    let reads_derivative = (exprs.leaves(level).iter())
        .any(|l| matches!(l, Symbol::Sensor(_, n) | Symbol::Input(_, n) | Symbol::Auxiliary(_, n) | Symbol::Root(_, n) if *n + 1 >= top && *n > 0));
    if reads_derivative {
        return None;
    }
    let rate_of_c = Derivatives::new(time_rate).exact().of(exprs, c)?;
    let drift = exprs.mul(rate_of_c, level);
    let rate = match x.rate {
        Some(r) => {
            let scaled = exprs.mul(c, r);
            exprs.sub(scaled, drift)
        }
        None => exprs.neg(drift),
    };
    Some(Split {
        level: Some(exprs.mul(c, level)),
        rate: Some(rate),
    })
}

/// A leaf's time derivative: a signal's next derivative, 0 for a parameter, 1 for time (none
/// for what a relation realised by integration cannot read).
pub fn time_rate(p: &mut Exprs, s: Symbol) -> Option<Expr> {
    match s {
        Symbol::Sensor(h, n) => Some(p.leaf(Symbol::Sensor(h, n + 1))),
        Symbol::Input(u, n) => Some(p.leaf(Symbol::Input(u, n + 1))),
        Symbol::Parameter(_) => Some(p.num(0.0)),
        Symbol::Time => Some(p.num(1.0)),
        Symbol::Root(h, n) => Some(p.leaf(Symbol::Root(h, n + 1))),
        Symbol::Auxiliary(..) | Symbol::State(_) | Symbol::Loop(_) => None,
    }
}

fn map(exprs: &mut Exprs, s: Split, mut f: impl FnMut(&mut Exprs, Expr) -> Expr) -> Split {
    Split {
        level: s.level.map(|x| f(exprs, x)),
        rate: s.rate.map(|x| f(exprs, x)),
    }
}

fn combine(exprs: &mut Exprs, a: Split, b: Split, plus: bool) -> Split {
    let mut join = |x: Option<Expr>, y: Option<Expr>| match (x, y) {
        (x, None) => x,
        (None, Some(y)) => Some(if plus { y } else { exprs.neg(y) }),
        (Some(x), Some(y)) => Some(if plus {
            exprs.add(x, y)
        } else {
            exprs.sub(x, y)
        }),
    };
    let level = join(a.level, b.level);
    let rate = join(a.rate, b.rate);
    Split { level, rate }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use crate::product::{Compiled, Expr, Realisation, Symbol};
    use crate::symbolic::{Derivatives, Evaluator, Node};
    use crate::{compile, Options, Realise};

    fn compiled(text: &str, realise: Realise) -> Compiled {
        compiled_with(text, realise, crate::ResidualSet::PerSensor)
    }

    fn compiled_with(text: &str, realise: Realise, residuals: crate::ResidualSet) -> Compiled {
        let options = Options {
            realise,
            residuals,
            ..Options::default()
        };
        let c = compile(text, "test.bg", &options).expect("valid").compiled;
        assert!(!c.has_errors(), "{:?}", c.diagnostics);
        c
    }

    const MOTOR: &str = "model m\nparam Re = 0.3\nparam L = 0.5\nparam ke = 0.5\nparam Je = 0.8\nparam fe = 0.1\ninput U0\nSe U = U0\nR Rm = Re\nI Lm = L\nGY motor = ke\nI Jm = Je\nR fm = fe\nDf i on elec\nDf y1 on shaft\nU -> 1:elec -> Rm, Lm\nelec -> motor -> 1:shaft -> Jm, fm\n";

    /// `r` at arbitrary values of its leaves and of each `int(..)` node.
    fn value(c: &Compiled, e: Expr, seed: f64) -> f64 {
        let leaf = |s: Symbol| {
            let h = format!("{s:?}")
                .bytes()
                .fold(seed, |a, b| (a * 31.0 + f64::from(b)) % 97.0);
            0.1 + h / 50.0
        };
        let mut integrals = HashMap::new();
        c.exprs.visit_reachable(&[e], |id, node| {
            if let Node::Int(_) = node {
                integrals.insert(id, 0.2 + (id.index() as f64 * 0.37 + seed) % 1.3);
            }
        });
        Evaluator::new(&c.exprs, leaf)
            .with_integrals(integrals)
            .value(e)
    }

    /// The motor's ARRs, read by hand: `U0 − Re·i − L·i' − ke·y1` is `d(−L·i)/dt` plus
    /// `U0 − Re·i − ke·y1`, and its integral reads no derivative at all.
    #[test]
    fn the_motor_is_realised_without_derivatives() {
        let c = compiled(MOTOR, Realise::Lowest);
        for arr in &c.arrs {
            assert!(
                matches!(arr.realisation, Realisation::Integrated(_)),
                "{}",
                arr.name
            );
            assert_eq!(arr.realised_order(), 0, "{}", arr.name);
        }
        let Realisation::Integrated(i) = &c.arrs[0].realisation else {
            unreachable!()
        };
        let name = |s: Symbol| match s {
            Symbol::Parameter(p) => c.parameters[p].name.clone(),
            Symbol::Sensor(h, 0) => c.sensors[h].name.clone(),
            Symbol::Input(u, 0) => c.inputs[u].name.clone(),
            other => format!("{other:?}"),
        };
        let text = |e| crate::Printer::new(&c.exprs, name).text(e);
        assert_eq!(text(i.level), "-(L * i)");
        assert_eq!(text(i.rate), "U0 - Re * i - ke * y1");
        assert_eq!(
            text(i.expr),
            "-(L * i) + int(U0) - Re * int(i) - ke * int(y1)"
        );
        let direct = compiled(MOTOR, Realise::Direct);
        assert!(direct
            .arrs
            .iter()
            .all(|a| a.realisation == Realisation::Direct));
        assert_eq!(direct.arrs[0].realised_order(), 1);
    }

    /// An encoder's axis, read by hand: `tau - M·x'' - b·x' - Fc·sign(x') = 0` is the
    /// derivative of `-(M·x') - b·x` plus `tau - Fc·sign(x')`: the friction's sign reads the
    /// first derivative pointwise, so it goes to the rate whole, and nothing reads `x''`.
    #[test]
    fn a_position_encoders_relation_reads_one_derivative_fewer() {
        let axis = "model a\nparam M = 90\nparam b = 180\nparam Fc = 15\ninput tau\n\
                    Se drive = tau\nI load = M\nR visc = b\nR dry : e = Fc*sign(f)\n\
                    Dq x on j\ndrive -> 1:j -> load, visc, dry\n";
        let c = compiled(axis, Realise::Lowest);
        let Realisation::Integrated(i) = &c.arrs[0].realisation else {
            panic!("{:?}", c.arrs[0].realisation)
        };
        assert_eq!(c.arrs[0].realised_order(), 1);
        let name = |s: Symbol| match s {
            Symbol::Parameter(p) => c.parameters[p].name.clone(),
            Symbol::Sensor(h, 0) => c.sensors[h].name.clone(),
            Symbol::Sensor(h, n) => format!("der({}, {n})", c.sensors[h].name),
            Symbol::Input(u, 0) => c.inputs[u].name.clone(),
            other => format!("{other:?}"),
        };
        let text = |e| crate::Printer::new(&c.exprs, name).text(e);
        assert_eq!(text(i.level), "-(M * der(x, 1)) - b * x");
        assert_eq!(text(i.rate), "tau - Fc * sign(der(x, 1))");
    }

    /// On every model of `models/`, one ARR per detector and the `best` residuals, each
    /// integrated ARR is its rate plus its level's time derivative: the identity holds at
    /// arbitrary values of the signals, their derivatives and integrals. Among them, the
    /// bench's third `best` ARR, whose first derivatives have coefficients that vary with the
    /// twist (the product rule).
    #[test]
    fn every_split_is_an_identity() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models");
        let mut paths: Vec<_> = std::fs::read_dir(dir)
            .expect("models")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "bg"))
            .collect();
        paths.sort();
        let mut checked = 0;
        let sets = [crate::ResidualSet::PerSensor, crate::ResidualSet::Best];
        for (path, set) in paths.iter().flat_map(|p| sets.map(|s| (p, s))) {
            let text = std::fs::read_to_string(path).expect("readable");
            let mut c = compiled_with(&text, Realise::Lowest, set);
            for k in 0..c.arrs.len() {
                let Realisation::Integrated(i) = c.arrs[k].realisation.clone() else {
                    continue;
                };
                let mut d = Derivatives::new(super::time_rate);
                let dl = d.of(&mut c.exprs, i.level).expect("differentiable");
                let sum = c.exprs.add(i.rate, dl);
                let expr = c.arrs[k].expr;
                for seed in [1.0, 2.5, 7.0] {
                    let (a, b) = (value(&c, sum, seed), value(&c, expr, seed));
                    assert!(
                        (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0),
                        "{}: {}: {a} against {b}",
                        path.display(),
                        c.arrs[k].name
                    );
                }
                assert!(c.arrs[k].realised_order() < max_order(&c.arrs[k]));
                checked += 1;
            }
        }
        assert!(checked >= 60, "only {checked} integrated ARRs");
    }

    /// The bench's `best` ARR without the load reads `y1'''` and first derivatives whose
    /// coefficients vary with the twist: the product rule integrates it all the same.
    #[test]
    fn coefficients_that_vary_through_integrals_integrate_by_the_product_rule() {
        let text = include_str!("../../../../models/backlash_bench.bg");
        let c = compiled_with(text, Realise::Lowest, crate::ResidualSet::Best);
        let arr = (c.arrs.iter())
            .find(|a| max_order(a) == 3)
            .expect("an ARR of order 3");
        assert!(matches!(arr.realisation, Realisation::Integrated(_)));
        assert_eq!(arr.realised_order(), 2);
    }

    fn max_order(arr: &crate::product::Arr) -> u32 {
        (arr.reads.iter())
            .filter_map(|r| r.orders.last().copied())
            .max()
            .unwrap_or(0)
    }
}
