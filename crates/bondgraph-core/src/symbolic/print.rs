//! Expressions as text: the plain infix of the JSON contract, and LaTeX.

use std::fmt::Write as _;

use super::pool::{ExprId, LeafKind, Node, Pool};
use crate::expr::{BinOp, Func};

/// Writes expressions of one pool, naming leaves with a closure.
pub struct Printer<'p, L: LeafKind, F> {
    pool: &'p Pool<L>,
    name: F,
}

/// Binding strength of a printed node: 1 sums, 2 products, 3 unary minus, 4 powers, 5 atoms.
/// A number printed as a fraction binds as a quotient.
pub(crate) fn precedence<L: LeafKind>(node: Node<L>) -> u8 {
    match node {
        Node::Binary(op, ..) => op.precedence(),
        Node::Neg(_) => 3,
        Node::Num(bits) if fraction(f64::from_bits(bits)).is_some() => 2,
        Node::Num(bits) if f64::from_bits(bits) < 0.0 => 3,
        _ => 5,
    }
}

/// The largest denominator a number is printed over.
const DENOMINATOR: u64 = 1000;

/// How far from `p/q`, in units of the last place, a number may be and still be printed as
/// `p/q`: what the arithmetic that made it (a power `(2/3)*(-1)`, `1 - 5/3`) leaves.
const ULPS: f64 = 4.0;

/// `x` as the fraction `p/q` (q from 2 to [`DENOMINATOR`], the smallest) that it is the
/// double of, to a few units of the last place, where its decimal form is not short (at
/// least 10 significant digits): `1/3`, not `0.3333333333333333`, and `-2/3`, not
/// `-0.6666666666666667`, so that an exact reading of the output (a computer algebra check)
/// finds the relation that was derived; `0.5` and `0.125` stay as they are.
pub(crate) fn fraction(x: f64) -> Option<(i64, u64)> {
    if !x.is_finite() || x == 0.0 || x.abs() > 1e6 {
        return None;
    }
    let digits = format!("{:e}", x.abs());
    let mantissa = digits.split('e').next().unwrap_or("");
    if mantissa.chars().filter(char::is_ascii_digit).count() < 10 {
        return None;
    }
    (2..=DENOMINATOR).find_map(|q| {
        let p = (x * q as f64).round();
        let close = (x - p / q as f64).abs() <= ULPS * f64::EPSILON * x.abs();
        (close && p != 0.0).then_some((p as i64, q))
    })
}

/// A number as the text prints it: a fraction where it is one (see [`fraction`]).
fn number_text(x: f64) -> String {
    match fraction(x) {
        Some((p, q)) => format!("{p}/{q}"),
        None => format!("{x}"),
    }
}

impl<'p, L: LeafKind, F: Fn(L) -> String> Printer<'p, L, F> {
    /// A printer over `pool` with leaf names from `name`.
    pub fn new(pool: &'p Pool<L>, name: F) -> Self {
        Printer { pool, name }
    }

    /// Plain infix: `+ - * / ^`, calls, `der(y, n)`, `int(..)`.
    pub fn text(&self, root: ExprId<L>) -> String {
        let mut out = String::new();
        self.text_into(&mut out, root, 0);
        out
    }

    fn text_into(&self, out: &mut String, id: ExprId<L>, outer: u8) {
        let node = self.pool.node(id);
        let paren = precedence(node) < outer;
        if paren {
            out.push('(');
        }
        match node {
            Node::Num(bits) => out.push_str(&number_text(f64::from_bits(bits))),
            Node::Leaf(l) => out.push_str(&(self.name)(l)),
            Node::Neg(a) => {
                out.push('-');
                self.text_into(out, a, 3);
            }
            Node::Binary(BinOp::Pow, a, b) => {
                let (lp, rp) = BinOp::Pow.operand_precedence();
                self.text_into(out, a, lp);
                out.push_str(" ^ ");
                self.text_into(out, b, rp);
            }
            Node::Binary(op, ..) => {
                let (first, rest) = self.chain(id, |o| o.precedence() == op.precedence());
                self.text_into(out, first, op.operand_precedence().0);
                for (op, b) in rest {
                    // `a * (1 / y)` reads `a / y`, not `a * 1 / y`; a quotient's sharing
                    // with other uses of `1 / y` stays in the pool.
                    let (op, b) = match (op, self.pool.node(b)) {
                        (BinOp::Mul, Node::Binary(BinOp::Div, one, y))
                            if self.pool.as_num(one) == Some(1.0) =>
                        {
                            (BinOp::Div, y)
                        }
                        _ => (op, b),
                    };
                    let _ = write!(out, " {} ", op.symbol());
                    self.text_into(out, b, op.operand_precedence().1);
                }
            }
            Node::Call1(f, a) => {
                let _ = write!(out, "{}(", f.name());
                self.text_into(out, a, 0);
                out.push(')');
            }
            Node::Call2(f, a, b) => {
                let _ = write!(out, "{}(", f.name());
                self.text_into(out, a, 0);
                out.push_str(", ");
                self.text_into(out, b, 0);
                out.push(')');
            }
            Node::Int(a) => {
                out.push_str("int(");
                self.text_into(out, a, 0);
                out.push(')');
            }
        }
        if paren {
            out.push(')');
        }
    }

    /// LaTeX math (no surrounding `$`); leaf names are used as given.
    pub fn latex(&self, root: ExprId<L>) -> String {
        let mut out = String::new();
        self.latex_into(&mut out, root, 0);
        out
    }

    /// The terms of the top-level sum of `root` with their signs (`true` for plus): `root`
    /// itself, with a plus, when it is not a sum. A negated sum is kept whole.
    pub fn terms(&self, root: ExprId<L>) -> Vec<(bool, ExprId<L>)> {
        let (inner, negated) = match self.pool.node(root) {
            Node::Neg(a) => (a, true),
            _ => (root, false),
        };
        let (first, rest) = self.chain(inner, |o| o.precedence() == 1);
        if negated && !rest.is_empty() {
            return vec![(true, root)];
        }
        let mut out = vec![(!negated, first)];
        out.extend(rest.into_iter().map(|(op, b)| (op == BinOp::Add, b)));
        out
    }

    /// LaTeX of one term of a sum: grouped as a term after a sign needs.
    pub fn latex_term(&self, term: ExprId<L>, alone: bool) -> String {
        let mut text = String::new();
        self.latex_into(&mut text, term, if alone { 0 } else { 2 });
        text
    }

    /// The terms of the top-level sum, each in LaTeX with its sign (`true` for plus), so that
    /// a long equation can be broken between them.
    pub fn latex_terms(&self, root: ExprId<L>) -> Vec<(bool, String)> {
        let (root, negated) = match self.pool.node(root) {
            Node::Neg(a) => (a, true),
            _ => (root, false),
        };
        let (first, rest) = self.chain(root, |o| o.precedence() == 1);
        let mut terms = Vec::with_capacity(rest.len() + 1);
        // A term keeps the grouping a difference needs: it follows a sign.
        let outer = if rest.is_empty() { 0 } else { 2 };
        let mut push = |plus: bool, id: ExprId<L>| {
            let mut text = String::new();
            self.latex_into(&mut text, id, outer);
            terms.push((plus != negated, text));
        };
        if negated && !rest.is_empty() {
            // -(a + b) is not -a + b: keep it whole.
            let mut text = String::new();
            self.latex_into(&mut text, root, 3);
            return vec![(false, text)];
        }
        push(true, first);
        for (op, b) in rest {
            push(op == BinOp::Add, b);
        }
        terms
    }

    fn latex_into(&self, out: &mut String, id: ExprId<L>, outer: u8) {
        let node = self.pool.node(id);
        // A fraction groups its parts itself.
        let own = match node {
            Node::Binary(BinOp::Div, ..) => 5,
            Node::Num(bits) => match fraction(f64::from_bits(bits)) {
                Some((p, _)) if p < 0 => 3,
                Some(_) => 5,
                None => precedence(node),
            },
            n => precedence(n),
        };
        let paren = own < outer;
        if paren {
            out.push_str("\\left(");
        }
        match node {
            Node::Num(bits) => match fraction(f64::from_bits(bits)) {
                Some((p, q)) if p < 0 => {
                    let _ = write!(out, "-\\frac{{{}}}{{{q}}}", p.unsigned_abs());
                }
                Some((p, q)) => {
                    let _ = write!(out, "\\frac{{{p}}}{{{q}}}");
                }
                None => {
                    let _ = write!(out, "{}", f64::from_bits(bits));
                }
            },
            Node::Leaf(l) => out.push_str(&(self.name)(l)),
            Node::Neg(a) => {
                out.push('-');
                self.latex_into(out, a, 3);
            }
            Node::Binary(BinOp::Div, a, b) => {
                out.push_str("\\frac{");
                self.latex_into(out, a, 0);
                out.push_str("}{");
                self.latex_into(out, b, 0);
                out.push('}');
            }
            Node::Binary(BinOp::Pow, a, b) => {
                out.push('{');
                self.latex_into(out, a, 5);
                out.push_str("}^{");
                self.latex_into(out, b, 0);
                out.push('}');
            }
            Node::Binary(op, ..) => {
                // Sums, and products without a fraction: a fraction is drawn by itself.
                let (first, rest) = self.chain(id, |o| {
                    o == op || (o.precedence() == 1 && op.precedence() == 1)
                });
                self.latex_into(out, first, op.operand_precedence().0);
                for (op, b) in rest {
                    out.push_str(match op {
                        BinOp::Add => " + ",
                        BinOp::Sub => " - ",
                        _ => " \\, ",
                    });
                    self.latex_into(out, b, op.operand_precedence().1);
                }
            }
            Node::Call1(Func::Sqrt, a) => {
                out.push_str("\\sqrt{");
                self.latex_into(out, a, 0);
                out.push('}');
            }
            Node::Call1(Func::Abs, a) => {
                out.push_str("\\left|");
                self.latex_into(out, a, 0);
                out.push_str("\\right|");
            }
            Node::Call1(f, a) => {
                out.push_str(latex_function(f));
                out.push_str("\\left(");
                self.latex_into(out, a, 0);
                out.push_str("\\right)");
            }
            Node::Call2(f, a, b) => {
                out.push_str(latex_function(f));
                out.push_str("\\left(");
                self.latex_into(out, a, 0);
                out.push_str(", ");
                self.latex_into(out, b, 0);
                out.push_str("\\right)");
            }
            Node::Int(a) => {
                out.push_str("\\int_0^t ");
                self.latex_into(out, a, 2);
                out.push_str(" \\, d\\tau");
            }
        }
        if paren {
            out.push_str("\\right)");
        }
    }
}

impl<L: LeafKind, F> Printer<'_, L, F> {
    /// The operands of a left-nested chain of operators that `joins` accepts, leftmost
    /// first, with the operator before each of the others. A canonical sum of ten thousand
    /// terms is a chain ten thousand deep: walked here, not recursed into.
    fn chain(
        &self,
        id: ExprId<L>,
        joins: impl Fn(BinOp) -> bool,
    ) -> (ExprId<L>, Vec<(BinOp, ExprId<L>)>) {
        let mut rest = Vec::new();
        let mut left = id;
        while let Node::Binary(op, a, b) = self.pool.node(left) {
            if !joins(op) || op == BinOp::Pow {
                break;
            }
            rest.push((op, b));
            left = a;
        }
        rest.reverse();
        (left, rest)
    }
}

fn latex_function(f: Func) -> &'static str {
    match f {
        Func::Exp => "\\exp",
        Func::Log => "\\ln",
        Func::Sqrt => "\\operatorname{sqrt}",
        Func::Abs => "\\operatorname{abs}",
        Func::Sign => "\\operatorname{sign}",
        Func::Sin => "\\sin",
        Func::Cos => "\\cos",
        Func::Tan => "\\tan",
        Func::Tanh => "\\tanh",
        Func::Atan => "\\arctan",
        Func::Atanh => "\\operatorname{artanh}",
        Func::Min => "\\min",
        Func::Max => "\\max",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::ParamId;

    /// A JSON sensitivity `∂r/∂fe` was printed `y1 * Re * 1 / ke`.
    #[test]
    fn a_product_with_a_reciprocal_prints_as_a_quotient() {
        use crate::symbolic::Leaf;
        let mut p: Pool<Leaf> = Pool::default();
        let [y, re, ke] = [0, 1, 2].map(|k| p.leaf(Leaf::Param(ParamId(k))));
        let one = p.num(1.0);
        let reciprocal = p.div(one, ke);
        let product = p.mul(y, re);
        let scaled = p.mul(product, reciprocal);
        let sum = p.add(scaled, y);
        let reciprocal_of_sum = p.div(one, sum);
        let outer = p.mul(re, reciprocal_of_sum);
        let names = ["y1", "Re", "ke"];
        let printer = Printer::new(&p, |l| match l {
            Leaf::Param(ParamId(k)) => names[k as usize].to_string(),
            _ => "?".to_string(),
        });
        assert_eq!(printer.text(scaled), "y1 * Re / ke");
        assert_eq!(printer.text(outer), "Re / (y1 * Re / ke + y1)");
        assert_eq!(printer.text(reciprocal), "1 / ke");
    }
    use crate::symbolic::Leaf;

    /// Rational numbers print exactly, also one unit of the last place off (what `1 - 5/3`
    /// leaves), and only where their decimal form is long; as operands they bind as the
    /// quotients they are.
    #[test]
    fn rational_numbers_print_as_fractions_and_short_decimals_as_they_are() {
        assert_eq!(fraction(1.0 / 3.0), Some((1, 3)));
        assert_eq!(fraction(-0.6666666666666667), Some((-2, 3)));
        assert_eq!(fraction(1.0 - 5.0 / 3.0), Some((-2, 3)));
        assert_eq!(fraction(22.0 / 7.0), Some((22, 7)));
        for short in [0.5, 0.125, -0.25, 1.5, 3.0, 0.1, 1e-3] {
            assert_eq!(fraction(short), None, "{short}");
        }
        // Not a fraction of a small denominator: pi, e, a measured value.
        for other in [std::f64::consts::PI, std::f64::consts::E, 0.123456789012] {
            assert_eq!(fraction(other), None, "{other}");
        }
        let mut pool = Pool::default();
        let x = pool.leaf(Leaf::Param(ParamId(0)));
        let third = pool.num(1.0 / 3.0);
        let minus_two_thirds = pool.num(-0.6666666666666667);
        let product = pool.binary(BinOp::Mul, third, x);
        let power = pool.binary(BinOp::Pow, x, minus_two_thirds);
        let quotient = pool.binary(BinOp::Div, x, third);
        let printer = Printer::new(&pool, |_| "x".to_string());
        assert_eq!(printer.text(product), "1/3 * x");
        assert_eq!(printer.text(power), "x ^ (-2/3)");
        assert_eq!(printer.text(quotient), "x / (1/3)");
        assert_eq!(printer.latex(power), "{x}^{-\\frac{2}{3}}");
    }

    /// A canonical sum of many distinct terms is a left-nested chain as deep as it is long;
    /// printing it must not recurse that deep (a test thread has a small stack).
    #[test]
    fn a_sum_of_a_hundred_thousand_terms_prints_without_deep_recursion() {
        let mut pool = Pool::default();
        let n = 100_000u32;
        let terms: Vec<(bool, ExprId)> = (0..n)
            .map(|i| (i % 2 == 0, pool.leaf(Leaf::Param(ParamId(i)))))
            .collect();
        let sum = pool.signed_sum(&terms);
        let product = (0..n).fold(pool.num(2.0), |acc, i| {
            let x = pool.leaf(Leaf::Param(ParamId(i)));
            pool.mul(acc, x)
        });
        let printer = Printer::new(&pool, |l| match l {
            Leaf::Param(p) => format!("p{}", p.0),
            _ => String::new(),
        });
        let text = printer.text(sum);
        assert!(text.starts_with("p0 - p1 + p2 - p3"));
        assert!(text.ends_with("+ p99998 - p99999"));
        assert!(printer.text(product).starts_with("2 * p0 * p1 * p2"));
        assert!(printer.latex(sum).ends_with("+ p99998 - p99999"));
        assert!(printer.latex(product).starts_with("2 \\, p0 \\, p1"));
    }
}
