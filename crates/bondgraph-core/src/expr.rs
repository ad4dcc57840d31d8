//! Expressions as written in a model: laws, modulations, `let` definitions.
//!
//! One tree type serves both the syntax tree (leaves are names with spans) and the lowered model
//! (leaves are resolved symbols), so the two cannot drift apart.

use std::fmt;

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^`
    Pow,
}

impl BinOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Pow => "^",
        }
    }

    /// Every operator.
    pub const ALL: [BinOp; 5] = [BinOp::Add, BinOp::Sub, BinOp::Mul, BinOp::Div, BinOp::Pow];

    /// The operator written `symbol`, if any.
    pub fn from_symbol(symbol: &str) -> Option<BinOp> {
        BinOp::ALL.into_iter().find(|b| b.symbol() == symbol)
    }

    /// Its value at `a`, `b`.
    #[inline]
    pub fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::Pow => a.powf(b),
        }
    }

    /// The least binding strength the (left, right) operands need to be written without
    /// parentheses. `a + (b - c)` reads as `a + b - c` and `a * (b / c)` as `a * b / c`, so
    /// `+` and `*` accept their own kind on the right; `-` and `/` do not, and `^` groups
    /// to the right.
    pub fn operand_precedence(self) -> (u8, u8) {
        match self {
            BinOp::Add => (1, 1),
            BinOp::Sub => (1, 2),
            BinOp::Mul => (2, 2),
            BinOp::Div => (2, 3),
            BinOp::Pow => (5, 4),
        }
    }

    /// Binding strength: higher binds tighter.
    pub fn precedence(self) -> u8 {
        match self {
            BinOp::Add | BinOp::Sub => 1,
            BinOp::Mul | BinOp::Div => 2,
            BinOp::Pow => 4,
        }
    }
}

/// A function of the language.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// `exp(x)`
    Exp,
    /// `log(x)`, the natural logarithm.
    Log,
    /// `sqrt(x)`
    Sqrt,
    /// `abs(x)`
    Abs,
    /// `sign(x)`: -1, 0 or 1.
    Sign,
    /// `sin(x)`
    Sin,
    /// `cos(x)`
    Cos,
    /// `tan(x)`
    Tan,
    /// `tanh(x)`
    Tanh,
    /// `atan(x)`
    Atan,
    /// `atanh(x)`, the inverse of `tanh`, defined on (-1, 1).
    Atanh,
    /// `min(x, y)`
    Min,
    /// `max(x, y)`
    Max,
}

impl Func {
    /// Every function, in the order the documentation lists them.
    pub const ALL: [Func; 13] = [
        Func::Exp,
        Func::Log,
        Func::Sqrt,
        Func::Abs,
        Func::Sign,
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Tanh,
        Func::Atan,
        Func::Atanh,
        Func::Min,
        Func::Max,
    ];

    /// The function's name in the language.
    pub fn name(self) -> &'static str {
        match self {
            Func::Exp => "exp",
            Func::Log => "log",
            Func::Sqrt => "sqrt",
            Func::Abs => "abs",
            Func::Sign => "sign",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Tanh => "tanh",
            Func::Atan => "atan",
            Func::Atanh => "atanh",
            Func::Min => "min",
            Func::Max => "max",
        }
    }

    /// The function called `name`, if any.
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// How many arguments it takes.
    pub fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max => 2,
            _ => 1,
        }
    }

    /// Its value at `args`, which has [`Func::arity`] elements (a call node holds as many).
    #[inline]
    pub fn apply(self, args: &[f64]) -> f64 {
        let x = args[0];
        match self {
            Func::Exp => x.exp(),
            Func::Log => x.ln(),
            Func::Sqrt => x.sqrt(),
            Func::Abs => x.abs(),
            Func::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Tanh => x.tanh(),
            Func::Atan => x.atan(),
            Func::Atanh => x.atanh(),
            Func::Min => x.min(args[1]),
            Func::Max => x.max(args[1]),
        }
    }
}

/// An expression tree with leaves of type `L`.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr<L> {
    /// A number.
    Num(f64),
    /// A name.
    Leaf(L),
    /// `-x`
    Neg(Box<Expr<L>>),
    /// `x op y`
    Binary(BinOp, Box<Expr<L>>, Box<Expr<L>>),
    /// `f(x)` or `f(x, y)`
    Call(Func, Vec<Expr<L>>),
    /// `der(x, n)`: the n-th time derivative.
    Der(Box<Expr<L>>, u32),
    /// `int(x)`: the time integral from the start of the record.
    Int(Box<Expr<L>>),
}

impl<L> Expr<L> {
    /// The same tree with every leaf mapped by `f`; the first error stops the mapping.
    pub fn try_map<M, E>(&self, f: &mut impl FnMut(&L) -> Result<M, E>) -> Result<Expr<M>, E> {
        Ok(match self {
            Expr::Num(x) => Expr::Num(*x),
            Expr::Leaf(l) => Expr::Leaf(f(l)?),
            Expr::Neg(a) => Expr::Neg(Box::new(a.try_map(f)?)),
            Expr::Binary(op, a, b) => {
                Expr::Binary(*op, Box::new(a.try_map(f)?), Box::new(b.try_map(f)?))
            }
            Expr::Call(func, args) => Expr::Call(
                *func,
                args.iter()
                    .map(|a| a.try_map(f))
                    .collect::<Result<_, _>>()?,
            ),
            Expr::Der(a, n) => Expr::Der(Box::new(a.try_map(f)?), *n),
            Expr::Int(a) => Expr::Int(Box::new(a.try_map(f)?)),
        })
    }

    /// Calls `f` on every leaf, left to right.
    pub fn for_each_leaf<'a>(&'a self, f: &mut impl FnMut(&'a L)) {
        match self {
            Expr::Num(_) => {}
            Expr::Leaf(l) => f(l),
            Expr::Neg(a) | Expr::Der(a, _) | Expr::Int(a) => a.for_each_leaf(f),
            Expr::Binary(_, a, b) => {
                a.for_each_leaf(f);
                b.for_each_leaf(f);
            }
            Expr::Call(_, args) => args.iter().for_each(|a| a.for_each_leaf(f)),
        }
    }

    /// Shorthand for `a op b`.
    pub fn binary(op: BinOp, a: Expr<L>, b: Expr<L>) -> Expr<L> {
        Expr::Binary(op, Box::new(a), Box::new(b))
    }

    /// Writes the expression in the language's own syntax, naming leaves with `name`.
    pub fn write_with(
        &self,
        out: &mut impl fmt::Write,
        name: &impl Fn(&L) -> String,
    ) -> fmt::Result {
        self.write_prec(out, name, 0)
    }

    fn write_prec(
        &self,
        out: &mut impl fmt::Write,
        name: &impl Fn(&L) -> String,
        outer: u8,
    ) -> fmt::Result {
        match self {
            Expr::Num(x) => write_number(out, *x, outer),
            Expr::Leaf(l) => out.write_str(&name(l)),
            Expr::Neg(a) => {
                // Unary minus binds looser than `^` and tighter than `*`.
                let paren = outer > 2;
                open(out, paren)?;
                out.write_char('-')?;
                a.write_prec(out, name, 3)?;
                close(out, paren)
            }
            Expr::Binary(op, a, b) => {
                let p = op.precedence();
                let paren = p < outer;
                open(out, paren)?;
                // Left-associative ops need parentheses on a right operand of equal precedence;
                // `^` is right-associative, so the other way round.
                let (lp, rp) = if *op == BinOp::Pow {
                    (p + 1, p)
                } else {
                    (p, p + 1)
                };
                a.write_prec(out, name, lp)?;
                write!(out, " {} ", op.symbol())?;
                b.write_prec(out, name, rp)?;
                close(out, paren)
            }
            Expr::Call(func, args) => {
                write!(out, "{}(", func.name())?;
                write_args(out, name, args)?;
                out.write_char(')')
            }
            Expr::Der(a, 1) => {
                out.write_str("der(")?;
                a.write_prec(out, name, 0)?;
                out.write_char(')')
            }
            Expr::Der(a, n) => {
                out.write_str("der(")?;
                a.write_prec(out, name, 0)?;
                write!(out, ", {n})")
            }
            Expr::Int(a) => {
                out.write_str("int(")?;
                a.write_prec(out, name, 0)?;
                out.write_char(')')
            }
        }
    }
}

fn write_args<L>(
    out: &mut impl fmt::Write,
    name: &impl Fn(&L) -> String,
    args: &[Expr<L>],
) -> fmt::Result {
    for (i, a) in args.iter().enumerate() {
        if i > 0 {
            out.write_str(", ")?;
        }
        a.write_prec(out, name, 0)?;
    }
    Ok(())
}

fn write_number(out: &mut impl fmt::Write, x: f64, outer: u8) -> fmt::Result {
    let negative = x < 0.0 || (x == 0.0 && x.is_sign_negative());
    let paren = negative && outer > 2;
    open(out, paren)?;
    write!(out, "{x}")?;
    close(out, paren)
}

fn open(out: &mut impl fmt::Write, paren: bool) -> fmt::Result {
    if paren {
        out.write_char('(')?;
    }
    Ok(())
}

fn close(out: &mut impl fmt::Write, paren: bool) -> fmt::Result {
    if paren {
        out.write_char(')')?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(s: &str) -> Expr<String> {
        Expr::Leaf(s.to_string())
    }

    fn show(e: &Expr<String>) -> String {
        let mut s = String::new();
        e.write_with(&mut s, &|l: &String| l.clone()).unwrap();
        s
    }

    #[test]
    fn writes_only_the_parentheses_that_precedence_needs() {
        let a_minus_bc = Expr::binary(
            BinOp::Sub,
            leaf("a"),
            Expr::binary(BinOp::Sub, leaf("b"), leaf("c")),
        );
        assert_eq!(show(&a_minus_bc), "a - (b - c)");
        let ab_minus_c = Expr::binary(
            BinOp::Sub,
            Expr::binary(BinOp::Sub, leaf("a"), leaf("b")),
            leaf("c"),
        );
        assert_eq!(show(&ab_minus_c), "a - b - c");
        let pow = Expr::binary(
            BinOp::Pow,
            Expr::binary(BinOp::Pow, leaf("a"), leaf("b")),
            leaf("c"),
        );
        assert_eq!(show(&pow), "(a ^ b) ^ c");
        let neg_sq = Expr::Neg(Box::new(Expr::binary(
            BinOp::Pow,
            leaf("x"),
            Expr::Num(2.0),
        )));
        assert_eq!(show(&neg_sq), "-x ^ 2");
        let sq_neg = Expr::binary(BinOp::Pow, Expr::Neg(Box::new(leaf("x"))), Expr::Num(2.0));
        assert_eq!(show(&sq_neg), "(-x) ^ 2");
        let prod = Expr::binary(BinOp::Mul, Expr::Num(-4.0), leaf("K"));
        assert_eq!(show(&prod), "-4 * K");
        let sq = Expr::binary(BinOp::Pow, Expr::Num(-4.0), leaf("K"));
        assert_eq!(show(&sq), "(-4) ^ K");
        let der = Expr::Der(Box::new(leaf("y")), 2);
        assert_eq!(show(&der), "der(y, 2)");
    }

    #[test]
    fn functions_round_trip_by_name() {
        for f in Func::ALL {
            assert_eq!(Func::from_name(f.name()), Some(f));
        }
        assert_eq!(Func::from_name("expp"), None);
        assert_eq!(Func::Sign.apply(&[-3.0]), -1.0);
        assert_eq!(Func::Max.apply(&[1.0, 2.0]), 2.0);
    }
}
