//! Closed-form inversion: `y = f(x)` solved for `x`, for the laws users write.
//!
//! A law read the other way is the same law only where the inverse holds, so every inverse
//! comes with its domain: the conditions, over `y` and the parameters, under which the value
//! returned is the one solution (the principal root of an even power, the real branch of a
//! logarithm). What has no closed form here (`k1 q + k3 q^3`) gives `None`, and the caller
//! decides what to do instead (a co-energy state, an implicit unknown, a refusal).

use super::hash::FastMap;
use super::{children, ExprId, Leaf, Node, Pool, Simplifier, VarId};
use crate::expr::{BinOp, Func};

/// How a condition of a domain bounds its expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Bound {
    /// `x ≥ 0`
    NonNegative,
    /// `x > 0`
    Positive,
    /// `x ≠ 0`
    NonZero,
    /// `|x| < 1`
    BelowOne,
    /// `|x| < π/2`
    BelowHalfPi,
}

impl Bound {
    /// The condition on a printed expression, in the output's plain-text notation.
    pub(crate) fn describe(self, x: &str) -> String {
        match self {
            Bound::NonNegative => format!("{x} >= 0"),
            Bound::Positive => format!("{x} > 0"),
            Bound::NonZero => format!("{x} != 0"),
            Bound::BelowOne => format!("abs({x}) < 1"),
            Bound::BelowHalfPi => format!("abs({x}) < pi/2"),
        }
    }

    /// Whether a value satisfies it.
    pub(crate) fn holds(self, x: f64) -> bool {
        match self {
            Bound::NonNegative => x >= 0.0,
            Bound::Positive => x > 0.0,
            Bound::NonZero => x != 0.0,
            Bound::BelowOne => x.abs() < 1.0,
            Bound::BelowHalfPi => x.abs() < std::f64::consts::FRAC_PI_2,
        }
    }
}

/// One condition of an inverse's domain: `expr` within `bound`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Condition {
    /// What is bounded, over the inverse's argument and parameters.
    pub expr: ExprId,
    /// How.
    pub bound: Bound,
}

/// `x` as a function of `y`, and where that holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Inverse {
    /// The value of `x`, over `y` and whatever else `f` read.
    pub value: ExprId,
    /// The conditions under which `value` is the solution; empty when it always is.
    pub domain: Vec<Condition>,
}

/// Solves `y = f` for the leaf `x` in closed form, or `None` when this module knows no way.
pub(crate) fn invert(pool: &mut Pool, f: ExprId, x: Leaf, y: ExprId) -> Option<Inverse> {
    let mut inverter = Inverter {
        pool,
        domain: Vec::new(),
        placeholders: 0,
        holding: FastMap::default(),
    };
    // Left as built: the inverse reads as the law undone step by step (`e = (f/c)^2`), which
    // a canonical form would obscure; later stages simplify what they derive from it.
    let value = inverter.solve(f, x, y)?;
    let mut domain: Vec<Condition> = Vec::new();
    for c in std::mem::take(&mut inverter.domain) {
        match inverter.pool.as_num(c.expr) {
            Some(v) if c.bound.holds(v) => {}
            // A condition that never holds leaves no domain: no inverse at all.
            Some(_) => return None,
            // A divisor made of parameters only is a condition on the model, not on where the
            // inverse holds: a law that divides by a zero parameter is not the law written.
            None if c.bound == Bound::NonZero && constant(inverter.pool, c.expr) => {}
            // `(abs(f)/c)^2 >= 0` holds whatever f and c, and `abs(e)/kl >= 0` whatever e once
            // kl is positive: what is left is the sign of parameters, a condition on the model
            // (a loss coefficient written negative), as a divisor of parameters is. Stated, it
            // read as a tautology (`abs(e) / kl >= 0 and (abs(e) / kl) ^ 0.5 >= 0`).
            None if c.bound == Bound::NonNegative && nonnegative(inverter.pool, c.expr) => {}
            None if !domain.contains(&c) => domain.push(c),
            None => {}
        }
    }
    Some(Inverse { value, domain })
}

/// Whether `e` reads parameters and numbers only.
fn constant(pool: &Pool, e: ExprId) -> bool {
    pool.leaves(e).iter().all(|l| matches!(l, Leaf::Param(_)))
}

/// Whether `e` is non-negative whatever its leaves: an absolute value, a square root, an
/// exponential, an even power, or sums, products and quotients of those and of non-negative
/// numbers.
fn nonnegative(pool: &Pool, e: ExprId) -> bool {
    match pool.node(e) {
        Node::Num(bits) => f64::from_bits(bits) >= 0.0,
        // The sign of parameters is the model's to get right (see `invert`).
        Node::Leaf(Leaf::Param(_)) => true,
        Node::Call1(Func::Abs | Func::Sqrt | Func::Exp, _) => true,
        Node::Binary(BinOp::Pow, a, k) => {
            // A principal root (`^0.5`) is non-negative wherever it is a number.
            let even_or_root = pool
                .as_num(k)
                .is_some_and(|k| k.fract() != 0.0 || (k as i64) % 2 == 0);
            even_or_root || nonnegative(pool, a)
        }
        Node::Binary(BinOp::Mul | BinOp::Div | BinOp::Add, a, b) => {
            nonnegative(pool, a) && nonnegative(pool, b)
        }
        _ => false,
    }
}

/// Placeholder leaves stand for a subexpression (`abs(u)`) while the rest is solved for it;
/// they never leave this module.
const PLACEHOLDER: VarId = VarId(u32::MAX - 1);

struct Inverter<'p> {
    pool: &'p mut Pool,
    domain: Vec<Condition>,
    placeholders: u32,
    /// Whether each (expression, target) holds the target, for the nodes met so far: the
    /// search asks it of every operand on its way down, which would otherwise cost the size
    /// of the law at each step (a law may be a long `let` written out).
    holding: FastMap<(ExprId, ExprId), bool>,
}

impl Inverter<'_> {
    fn holds(&mut self, e: ExprId, x: ExprId) -> bool {
        if let Some(&known) = self.holding.get(&(e, x)) {
            return known;
        }
        let mut order = Vec::new();
        self.pool
            .visit_reachable(&[e], |id, node| order.push((id, node)));
        for (id, node) in order {
            if self.holding.contains_key(&(id, x)) {
                continue;
            }
            let held = id == x
                || children(node).any(|c| self.holding.get(&(c, x)).copied().unwrap_or(false));
            self.holding.insert((id, x), held);
        }
        self.holding.get(&(e, x)).copied().unwrap_or(false)
    }

    fn require(&mut self, expr: ExprId, bound: Bound) {
        self.domain.push(Condition { expr, bound });
    }

    /// `x` from `y = f`, `x` a leaf.
    fn solve(&mut self, f: ExprId, x: Leaf, y: ExprId) -> Option<ExprId> {
        let target = self.pool.leaf(x);
        if f == target {
            return Some(y);
        }
        if !self.holds(f, target) {
            return None;
        }
        let in_one = match self.pool.node(f) {
            Node::Binary(_, a, b) => !(self.holds(a, target) && self.holds(b, target)),
            Node::Call2(..) | Node::Int(_) => false,
            _ => true,
        };
        if in_one {
            self.peel(f, x, y)
        } else {
            self.several(f, x, y)
        }
    }

    /// `f`'s outermost operation undone, `x` being in one operand only.
    fn peel(&mut self, f: ExprId, x: Leaf, y: ExprId) -> Option<ExprId> {
        let target = self.pool.leaf(x);
        match self.pool.node(f) {
            Node::Neg(a) => {
                let y = self.pool.neg(y);
                self.solve(a, x, y)
            }
            Node::Binary(op, a, b) => {
                let left = self.holds(a, target);
                let (inner, y) = self.undo(op, a, b, left, y)?;
                self.solve(inner, x, y)
            }
            Node::Call1(func, a) => {
                let y = self.function_inverse(func, y)?;
                self.solve(a, x, y)
            }
            _ => None,
        }
    }

    /// `y = a op b` with the unknown in `a` (`left`) or in `b`: the operand that holds it,
    /// and the value that operand must take.
    fn undo(
        &mut self,
        op: BinOp,
        a: ExprId,
        b: ExprId,
        left: bool,
        y: ExprId,
    ) -> Option<(ExprId, ExprId)> {
        let p = &mut *self.pool;
        Some(match (op, left) {
            (BinOp::Add, true) => (a, p.sub(y, b)),
            (BinOp::Add, false) => (b, p.sub(y, a)),
            (BinOp::Sub, true) => (a, p.add(y, b)),
            (BinOp::Sub, false) => (b, p.sub(a, y)),
            (BinOp::Mul, _) => {
                let (inner, k) = if left { (a, b) } else { (b, a) };
                let v = p.div(y, k);
                self.require(k, Bound::NonZero);
                (inner, v)
            }
            (BinOp::Div, true) => {
                let v = p.mul(y, b);
                self.require(b, Bound::NonZero);
                (a, v)
            }
            (BinOp::Div, false) => {
                let v = p.div(a, y);
                self.require(y, Bound::NonZero);
                (b, v)
            }
            (BinOp::Pow, true) => (a, self.root(y, b)?),
            (BinOp::Pow, false) => {
                let (ly, la) = (p.call(Func::Log, &[y]), p.call(Func::Log, &[a]));
                let v = p.div(ly, la);
                self.require(y, Bound::Positive);
                self.require(a, Bound::Positive);
                (b, v)
            }
        })
    }

    /// `a` from `y = a^k`: the real odd root of an odd integer power, the principal root of
    /// any other.
    fn root(&mut self, y: ExprId, k: ExprId) -> Option<ExprId> {
        let p = &mut *self.pool;
        let one = p.num(1.0);
        let inv_k = p.div(one, k);
        match p.as_num(k) {
            Some(0.0) => None,
            Some(n) if n.fract() == 0.0 && (n as i64) % 2 != 0 => {
                // sign(y)·|y|^(1/k): `y^(1/3)` of a negative y is not a number in f64.
                let s = p.call(Func::Sign, &[y]);
                let m = p.call(Func::Abs, &[y]);
                let r = p.pow(m, inv_k);
                Some(p.mul(s, r))
            }
            Some(n) => {
                let bound = if n > 0.0 {
                    Bound::NonNegative
                } else {
                    Bound::Positive
                };
                let r = p.pow(y, inv_k);
                self.require(y, bound);
                Some(r)
            }
            None => {
                let r = p.pow(y, inv_k);
                self.require(y, Bound::Positive);
                Some(r)
            }
        }
    }

    /// `a` from `y = func(a)`, on the branch the language's functions take.
    fn function_inverse(&mut self, func: Func, y: ExprId) -> Option<ExprId> {
        let p = &mut *self.pool;
        let (value, bound) = match func {
            Func::Sqrt => {
                let two = p.num(2.0);
                (p.pow(y, two), Some(Bound::NonNegative))
            }
            Func::Exp => (p.call(Func::Log, &[y]), Some(Bound::Positive)),
            Func::Log => (p.call(Func::Exp, &[y]), None),
            Func::Tanh => (p.call(Func::Atanh, &[y]), Some(Bound::BelowOne)),
            Func::Atanh => (p.call(Func::Tanh, &[y]), None),
            Func::Atan => (p.call(Func::Tan, &[y]), Some(Bound::BelowHalfPi)),
            Func::Tan => (p.call(Func::Atan, &[y]), None),
            Func::Abs | Func::Sign | Func::Sin | Func::Cos | Func::Min | Func::Max => return None,
        };
        if let Some(bound) = bound {
            self.require(y, bound);
        }
        Some(value)
    }

    /// `x` from `y = f` where `x` is in several operands: an odd law `sign(u)·g(|u|)`, a law
    /// affine in `x`, or a linear-fractional one.
    fn several(&mut self, f: ExprId, x: Leaf, y: ExprId) -> Option<ExprId> {
        if let Some(v) = self.odd(f, x, y) {
            return Some(v);
        }
        // The textbook forms of an odd law, `k·u·|u|` and `k·sign(u)·u²`: the same law as
        // `k·sign(u)·|u|²`, which `odd` solves.
        if let Some(g) = self.signed_power(f, x) {
            if let Some(v) = self.odd(g, x, y) {
                return Some(v);
            }
        }
        let target = self.pool.leaf(x);
        // The affine test samples three points, which a piecewise law (`max(x, 0)`) passes:
        // only sums, products and quotients of `x` may be affine or linear-fractional.
        if !self.rational(f, target) {
            return None;
        }
        let r = self.pool.sub(f, y);
        if let Some(v) = linear_root_of(self.pool, r, x) {
            return Some(v);
        }
        // y = n/d with n and d affine in x: y·d − n is affine in x.
        if let Node::Binary(BinOp::Div, n, d) = self.pool.node(f) {
            if self.holds(d, target) {
                let yd = self.pool.mul(y, d);
                let r = self.pool.sub(yd, n);
                let v = linear_root_of(self.pool, r, x)?;
                let at = self.pool.substitute(d, &mut |_, l| (l == x).then_some(v));
                self.require(at, Bound::NonZero);
                return Some(v);
            }
        }
        None
    }

    /// `y = sign(u)·g(|u|)`, with `sign(u)` a factor of `f` and `x` elsewhere only inside
    /// `abs(u)`: `|u| = g⁻¹(|y|)` and `u = sign(y)·|u|`, for `g ≥ 0`.
    fn odd(&mut self, f: ExprId, x: Leaf, y: ExprId) -> Option<ExprId> {
        let target = self.pool.leaf(x);
        let mut signs = Vec::new();
        self.pool.visit_reachable(&[f], |id, node| {
            if let Node::Call1(Func::Sign, _) = node {
                signs.push(id);
            }
        });
        for s in signs {
            let Node::Call1(_, u) = self.pool.node(s) else {
                continue;
            };
            if !self.holds(u, target) || !self.is_factor(f, s) {
                continue;
            }
            let one = self.pool.num(1.0);
            let g = self.pool.replace(f, s, one);
            let abs_u = self.pool.call(Func::Abs, &[u]);
            let placeholder = Leaf::Tear(PLACEHOLDER, self.placeholders);
            self.placeholders += 1;
            let m = self.pool.leaf(placeholder);
            let g = self.pool.replace(g, abs_u, m);
            if self.holds(g, target) {
                continue;
            }
            let abs_y = self.pool.call(Func::Abs, &[y]);
            let magnitude = self.solve(g, placeholder, abs_y)?;
            // `|u| = magnitude` needs it non-negative; `g(magnitude) = |y|` then holds as
            // solved, so sign(u) = sign(y) gives back y.
            self.require(magnitude, Bound::NonNegative);
            let sign_y = self.pool.call(Func::Sign, &[y]);
            let u_value = self.pool.mul(sign_y, magnitude);
            return self.solve(u, x, u_value);
        }
        None
    }

    /// `f` written as `rest·sign(u)·|u|^p` when it is a product (and quotient) of `rest`,
    /// free of `x`, and of factors `u`, `|u|`, `sign(u)` and `u^k`, `|u|^k` for numbers `k`,
    /// with `u` holding `x` and the signs odd in number: `u = sign(u)·|u|` and
    /// `u^k = |u|^k` for an even `k`. `None` for anything else (an even law has no inverse
    /// that knows the sign, and `u^0.5` is not odd).
    fn signed_power(&mut self, f: ExprId, x: Leaf) -> Option<ExprId> {
        let target = self.pool.leaf(x);
        let mut factors = Vec::new();
        self.factors(f, 1.0, &mut factors);
        let mut u = None;
        let (mut signs, mut power, mut holding) = (0i64, 0.0f64, 0usize);
        let mut others = Vec::new();
        for (e, k) in factors {
            if !self.holds(e, target) {
                others.push((e, k));
                continue;
            }
            holding += 1;
            let (base, exponent) = match self.pool.node(e) {
                Node::Binary(BinOp::Pow, b, n) => (b, self.pool.as_num(n)?),
                _ => (e, 1.0),
            };
            let (inner, is_abs, is_sign) = match self.pool.node(base) {
                Node::Call1(Func::Abs, a) => (a, true, false),
                Node::Call1(Func::Sign, a) => (a, false, true),
                _ => (base, false, false),
            };
            if *u.get_or_insert(inner) != inner || exponent.fract() != 0.0 && !is_abs {
                return None;
            }
            let times = exponent * k;
            if is_sign {
                signs += times as i64;
            } else {
                power += times;
                if !is_abs {
                    signs += times as i64;
                }
            }
        }
        let u = u?;
        // One factor holding `x` is no product of powers of `u` to gather (and gathering it
        // would give back `sign(u)·|u|`, whose `u` is the same factor again).
        if holding < 2 || signs.rem_euclid(2) == 0 || power == 0.0 {
            return None;
        }
        let p = &mut *self.pool;
        let (mut num, mut den): (Option<ExprId>, Option<ExprId>) = (None, None);
        for (e, k) in others {
            let side = if k > 0.0 { &mut num } else { &mut den };
            *side = Some(match *side {
                None => e,
                Some(r) => p.mul(r, e),
            });
        }
        let sign = p.call(Func::Sign, &[u]);
        let abs = p.call(Func::Abs, &[u]);
        let n = p.num(power);
        let magnitude = p.pow(abs, n);
        let mut g = p.mul(sign, magnitude);
        if let Some(r) = num {
            g = p.mul(r, g);
        }
        if let Some(r) = den {
            g = p.div(g, r);
        }
        Some(g)
    }

    /// The factors of `f` through products, quotients and negations, with their exponent
    /// (`1` in a numerator, `-1` in a denominator); a negation is kept as a factor `-1`.
    fn factors(&mut self, f: ExprId, k: f64, out: &mut Vec<(ExprId, f64)>) {
        match self.pool.node(f) {
            Node::Binary(BinOp::Mul, a, b) => {
                self.factors(a, k, out);
                self.factors(b, k, out);
            }
            Node::Binary(BinOp::Div, a, b) => {
                self.factors(a, k, out);
                self.factors(b, -k, out);
            }
            Node::Neg(a) => {
                let minus = self.pool.num(-1.0);
                out.push((minus, 1.0));
                self.factors(a, k, out);
            }
            _ => out.push((f, k)),
        }
    }

    /// Whether `x` reaches `f` through sums, products, quotients and negations only.
    fn rational(&mut self, f: ExprId, x: ExprId) -> bool {
        let mut nodes = Vec::new();
        self.pool.visit_reachable(&[f], |_, node| nodes.push(node));
        nodes.into_iter().all(|node| match node {
            Node::Call1(_, a) | Node::Int(a) => !self.holds(a, x),
            Node::Call2(_, a, b) | Node::Binary(BinOp::Pow, a, b) => {
                !self.holds(a, x) && !self.holds(b, x)
            }
            _ => true,
        })
    }

    /// Whether `f = s·rest` with `s` in `rest` nowhere: `s` reached from the root through
    /// products, numerators and negations only.
    fn is_factor(&mut self, f: ExprId, s: ExprId) -> bool {
        if f == s {
            return true;
        }
        match self.pool.node(f) {
            Node::Neg(a) => self.is_factor(a, s),
            Node::Binary(BinOp::Mul, a, b) => match (self.holds(a, s), self.holds(b, s)) {
                (true, false) => self.is_factor(a, s),
                (false, true) => self.is_factor(b, s),
                _ => false,
            },
            Node::Binary(BinOp::Div, a, b) => !self.holds(b, s) && self.is_factor(a, s),
            _ => false,
        }
    }
}

/// The root of `r` in the leaf `x`, if `r` is affine in it: with a = r(0) and b = r(1) − a,
/// r is affine when r(2) = a + 2b holds in canonical form, and then x = −a/b.
pub(crate) fn linear_root_of(pool: &mut Pool, r: ExprId, x: Leaf) -> Option<ExprId> {
    let at = |pool: &mut Pool, value: f64| {
        let n = pool.num(value);
        let e = pool.substitute(r, &mut |_, leaf| (leaf == x).then_some(n));
        Simplifier::default().simplify(pool, e)
    };
    let (a, one, two) = (at(pool, 0.0), at(pool, 1.0), at(pool, 2.0));
    let b = pool.sub(one, a);
    let b = Simplifier::default().simplify(pool, b);
    if pool.as_num(b) == Some(0.0) {
        return None;
    }
    let two_b = {
        let k = pool.num(2.0);
        pool.mul(k, b)
    };
    let predicted = pool.add(a, two_b);
    let predicted = Simplifier::default().simplify(pool, predicted);
    if predicted != two {
        return None;
    }
    let na = pool.neg(a);
    let root = pool.div(na, b);
    Some(Simplifier::default().simplify(pool, root))
}

#[cfg(test)]
mod tests {
    use super::super::Evaluator;
    use super::*;
    use crate::graph::ParamId;

    /// A parsed law over the leaf `x` (`Var(0)`) and parameters `c` = 2 (`Param(0)`), `k` = -3
    /// (`Param(1)`).
    fn law(p: &mut Pool, text: &str) -> ExprId {
        let e = crate::syntax::parse_expr(text, 0).expect("law parses");
        build(p, &e)
    }

    fn build(p: &mut Pool, e: &crate::syntax::ast::AstExpr) -> ExprId {
        use crate::expr::Expr;
        match e {
            Expr::Num(v) => p.num(*v),
            Expr::Leaf(i) => p.leaf(match i.name.as_str() {
                "x" => Leaf::Var(VarId(0)),
                "c" => Leaf::Param(ParamId(0)),
                _ => Leaf::Param(ParamId(1)),
            }),
            Expr::Neg(a) => {
                let a = build(p, a);
                p.neg(a)
            }
            Expr::Binary(op, a, b) => {
                let (a, b) = (build(p, a), build(p, b));
                p.binary(*op, a, b)
            }
            Expr::Call(f, args) => {
                let args: Vec<ExprId> = args.iter().map(|a| build(p, a)).collect();
                p.call(*f, &args)
            }
            Expr::Der(..) | Expr::Int(_) => p.num(f64::NAN),
        }
    }

    fn value(p: &Pool, e: ExprId, x: f64) -> f64 {
        Evaluator::new(p, |l| match l {
            Leaf::Var(VarId(0)) => x,
            Leaf::Param(ParamId(0)) => 2.0,
            Leaf::Param(_) => -3.0,
            _ => f64::NAN,
        })
        .value(e)
    }

    /// Each law, inverted, gives back every `x` of the samples within the stated domain, and
    /// the domain holds there.
    #[test]
    fn inverses_return_the_argument_on_their_domain() {
        let cases: &[(&str, &[f64])] = &[
            ("c*x + k", &[-2.0, 0.5, 3.0]),
            ("c*sqrt(x)", &[0.0, 0.3, 4.0]),
            ("x^2/c", &[0.0, 0.7, 5.0]),
            ("c*sign(x)*sqrt(abs(x))", &[-4.0, -0.1, 0.0, 2.5]),
            ("sign(x)*abs(x)^1.5*c", &[-2.0, 0.25, 3.0]),
            ("c*x^3", &[-2.0, 0.0, 1.5]),
            ("c*(1 - 4/x)", &[0.5, 3.0, 10.0]),
            ("(c*x + 1)/(x - k)", &[-1.0, 0.0, 2.0]),
            ("c*exp(x/c)", &[-1.0, 0.0, 2.0]),
            ("log(x) + c", &[0.1, 1.0, 7.0]),
            ("c*tanh(x)", &[-2.0, 0.0, 1.0]),
            ("atanh(x/c)", &[-1.5, 0.0, 1.9]),
            ("atan(x)*c", &[-5.0, 0.0, 5.0]),
            ("c^x", &[-1.0, 0.0, 2.0]),
            ("-(c*x)", &[-1.0, 3.0]),
            // The textbook forms of a quadratic loss: odd, as `c*sign(x)*abs(x)^2` is.
            ("c*x*abs(x)", &[-2.0, -0.3, 0.0, 1.5]),
            ("sign(x)*x^2*c", &[-2.0, 0.0, 0.7]),
            ("x*abs(x)^2/c", &[-1.2, 0.0, 4.0]),
            ("-(c*x^3*abs(x))", &[-1.1, 0.0, 0.9]),
        ];
        for (text, xs) in cases {
            let mut p = Pool::default();
            let f = law(&mut p, text);
            let y = p.leaf(Leaf::Var(VarId(1)));
            let inv = invert(&mut p, f, Leaf::Var(VarId(0)), y).unwrap_or_else(|| panic!("{text}"));
            for &x in *xs {
                let fy = value(&p, f, x);
                let at = |p: &Pool, e: ExprId| {
                    Evaluator::new(p, |l| match l {
                        Leaf::Var(VarId(1)) => fy,
                        Leaf::Param(ParamId(0)) => 2.0,
                        Leaf::Param(_) => -3.0,
                        _ => f64::NAN,
                    })
                    .value(e)
                };
                let back = at(&p, inv.value);
                assert!(
                    (back - x).abs() < 1e-9 * (1.0 + x.abs()),
                    "{text} at {x}: {back}"
                );
                for c in &inv.domain {
                    assert!(c.bound.holds(at(&p, c.expr)), "{text} at {x}: {c:?}");
                }
            }
        }
    }

    /// A law the module cannot invert is refused rather than guessed; so is a domain that is
    /// empty.
    #[test]
    fn laws_without_a_closed_form_are_refused() {
        for text in [
            "c*x + k*x^3",
            "sin(x)",
            "abs(x)",
            "x*exp(x)",
            "sign(x)*abs(x) + x^2",
            "max(x, 0)",
            "min(c*x, k)",
        ] {
            let mut p = Pool::default();
            let f = law(&mut p, text);
            let y = p.leaf(Leaf::Var(VarId(1)));
            assert_eq!(invert(&mut p, f, Leaf::Var(VarId(0)), y), None, "{text}");
        }
    }

    /// The orifice's `f = c·sqrt(e)` read backwards holds where `f/c ≥ 0`: the domain says so.
    #[test]
    fn an_odd_loss_has_no_domain_to_state() {
        for text in ["c*sign(x)*abs(x)^2", "c*x*abs(x)", "sign(x)*x^2*c"] {
            let mut p = Pool::default();
            let f = law(&mut p, text);
            let y = p.leaf(Leaf::Var(VarId(1)));
            let inv = invert(&mut p, f, Leaf::Var(VarId(0)), y).expect("invertible");
            assert!(inv.domain.is_empty(), "{text}: {:?}", inv.domain);
        }
        // An even law keeps no sign: it has no inverse.
        let mut p = Pool::default();
        let f = law(&mut p, "c*x*x");
        let y = p.leaf(Leaf::Var(VarId(1)));
        assert!(invert(&mut p, f, Leaf::Var(VarId(0)), y).is_none());
    }

    #[test]
    fn the_square_root_states_its_domain() {
        let mut p = Pool::default();
        let f = law(&mut p, "c*sqrt(x)");
        let y = p.leaf(Leaf::Var(VarId(1)));
        let inv = invert(&mut p, f, Leaf::Var(VarId(0)), y).expect("invertible");
        let bounds: Vec<Bound> = inv.domain.iter().map(|c| c.bound).collect();
        assert!(bounds.contains(&Bound::NonNegative), "{bounds:?}");
        // At y = -1 (c = 2) the inverse would give 1/4, which c·sqrt does not map to -1.
        let negative = inv.domain.iter().any(|c| {
            let v = Evaluator::new(&p, |l| match l {
                Leaf::Var(VarId(1)) => -1.0,
                Leaf::Param(_) => 2.0,
                _ => f64::NAN,
            })
            .value(c.expr);
            !c.bound.holds(v)
        });
        assert!(negative);
    }
}
