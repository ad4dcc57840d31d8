//! Program code printed as C expressions, with shared nodes bound once as `const double`s.

use std::cell::Cell;
use std::collections::HashMap;

use bondgraph_core::program::{Code, Leaf, Program, Slot};
use bondgraph_core::{BinOp, Compiled, Func, Handle, Node};

use super::names::ident;
use crate::rust::Unwritable;
use crate::sharing::{bindings, Binding};
use crate::signals::Field;

/// Binding strengths of C expressions as the lowering writes them.
const SUM: u8 = 1;
const PRODUCT: u8 = 2;
const UNARY: u8 = 3;
const ATOM: u8 = 5;

/// Where program code is printed: what time and the copy's leaves are called there.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Place {
    /// `residuals`, `bounds` and the laws of roots: slots as `s->NAME`; no time.
    Residuals,
    /// `push`, integrating a nonlinear expression at the estimates' instant `at`.
    Push,
    /// `copy_rates`: states `x[k]`, inputs `u[j]`, time `t`.
    Copy,
}

/// Prints program code as C, with shared nodes bound once.
pub(super) struct Lowering<'p> {
    c: &'p Compiled,
    program: &'p Program,
    place: Place,
    field: HashMap<Handle<Slot>, String>,
    bound: HashMap<Code, String>,
    refused: &'p Cell<Option<Unwritable>>,
    /// Whether `bgc_sign` and `bgc_powi` were printed: the runtime carries only what is read.
    pub(super) reads_sign: &'p Cell<bool>,
}

impl<'p> Lowering<'p> {
    pub(super) fn new(
        c: &'p Compiled,
        program: &'p Program,
        fields: &[Field],
        refused: &'p Cell<Option<Unwritable>>,
        reads_sign: &'p Cell<bool>,
        place: Place,
    ) -> Self {
        Lowering {
            c,
            program,
            place,
            field: fields.iter().map(|f| (f.slot, ident(&f.name))).collect(),
            bound: HashMap::new(),
            refused,
            reads_sign,
        }
    }

    /// `e` as C.
    pub(super) fn code(&self, e: Code) -> String {
        self.expr(e).0
    }

    fn expr(&self, e: Code) -> (String, u8) {
        if let Some(name) = self.bound.get(&e) {
            return (name.clone(), ATOM);
        }
        match self.program.code.node(e) {
            Node::Num(bits) => number(f64::from_bits(bits), self.refused),
            Node::Leaf(l) => (self.leaf(l), ATOM),
            Node::Neg(a) => {
                let a = self.operand(a, UNARY);
                // `--x` is a decrement in C.
                let a = if a.starts_with('-') {
                    format!("({a})")
                } else {
                    a
                };
                (format!("-{a}"), UNARY)
            }
            Node::Binary(BinOp::Pow, a, b) => {
                let (base, _) = self.expr(a);
                match self.program.code.node(b) {
                    Node::Num(bits)
                        if f64::from_bits(bits).fract() == 0.0
                            && f64::from_bits(bits).abs() < 64.0 =>
                    {
                        (
                            format!("bgc_powi({base}, {})", f64::from_bits(bits) as i32),
                            ATOM,
                        )
                    }
                    _ => (format!("pow({base}, {})", self.expr(b).0), ATOM),
                }
            }
            Node::Binary(op, a, b) => {
                let (prec, right, sign) = match op {
                    BinOp::Add => (SUM, SUM, "+"),
                    BinOp::Sub => (SUM, PRODUCT, "-"),
                    BinOp::Mul => (PRODUCT, PRODUCT, "*"),
                    _ => (PRODUCT, UNARY, "/"),
                };
                let left = self.operand(a, prec);
                let right = self.operand(b, right);
                (format!("{left} {sign} {right}"), prec)
            }
            Node::Call1(f, a) => (format!("{}({})", self.function(f), self.expr(a).0), ATOM),
            Node::Call2(f, a, b) => (
                format!(
                    "{}({}, {})",
                    self.function(f),
                    self.expr(a).0,
                    self.expr(b).0
                ),
                ATOM,
            ),
            Node::Int(_) => self.refuse("an integral the residual program did not make a slot"),
        }
    }

    /// A function's name in C: libm's, which the language's names are but for `abs`, `min`
    /// and `max` (C99's `fmin` and `fmax`, like Rust's, return the other of a NaN), and the
    /// runtime's `sign`.
    fn function(&self, f: Func) -> &'static str {
        match f {
            Func::Abs => "fabs",
            Func::Min => "fmin",
            Func::Max => "fmax",
            Func::Sign => {
                self.reads_sign.set(true);
                "bgc_sign"
            }
            f => f.name(),
        }
    }

    fn operand(&self, e: Code, needed: u8) -> String {
        let (text, prec) = self.expr(e);
        if prec < needed {
            format!("({text})")
        } else {
            text
        }
    }

    fn leaf(&self, l: Leaf) -> String {
        match (l, self.place) {
            (Leaf::Slot(h), _) => match self.field.get(&h) {
                Some(name) => format!("s->{name}"),
                None => {
                    self.refuse("a value the residuals read with no field to read it from")
                        .0
                }
            },
            (Leaf::Parameter(p), _) => format!("p->{}", ident(&self.c.parameters[p].name)),
            (Leaf::Time, Place::Copy) => "t".to_string(),
            (Leaf::Time, Place::Push) => "at".to_string(),
            (Leaf::State(k), Place::Copy) => format!("x[{}]", k.index()),
            (Leaf::Input(j), Place::Copy) => format!("u[{}]", j.index()),
            _ => {
                self.refuse("time or a state of the copy read outside the copy")
                    .0
            }
        }
    }

    fn refuse(&self, why: &'static str) -> (String, u8) {
        self.refused
            .set(self.refused.get().or(Some(Unwritable(why))));
        ("unwritable".to_string(), ATOM)
    }

    /// `const double` lines for every node of `roots` used more than once and for each named
    /// node that they read (named `name`, the others `prefix1`, `prefix2`…), bound from here
    /// on.
    pub(super) fn bind_shared(
        &mut self,
        roots: &[Code],
        named: &[(Code, String)],
        prefix: &str,
    ) -> Vec<String> {
        let mut lines = Vec::new();
        for (id, binding) in bindings(&self.program.code, roots, named) {
            let (value, _) = self.expr(id);
            let name = match binding {
                Binding::Named(name) => ident(name),
                Binding::Numbered(k) => format!("{prefix}{k}"),
            };
            lines.push(format!("    const double {name} = {value};"));
            self.bound.insert(id, name);
        }
        lines
    }
}

/// A number as a C literal (negative ones as a negation; infinities as `HUGE_VAL`). A NaN
/// cannot be computed with: the code is refused.
pub(super) fn number(x: f64, refused: &Cell<Option<Unwritable>>) -> (String, u8) {
    if x.is_nan() {
        refused.set(refused.get().or(Some(Unwritable(
            "a constant that is not a number (a division of zero by zero, or a law outside its domain, in the model's numbers)",
        ))));
        return ("unwritable".to_string(), ATOM);
    }
    if x.is_infinite() {
        return if x > 0.0 {
            ("HUGE_VAL".to_string(), ATOM)
        } else {
            ("-HUGE_VAL".to_string(), UNARY)
        };
    }
    // Rust's shortest round-trip form (`0.3`, `1e-7`, `5.0`) is a C double literal too.
    let text = format!("{:?}", x.abs());
    if x.is_sign_negative() && x != 0.0 {
        (format!("-{text}"), UNARY)
    } else {
        (text, ATOM)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers are C double literals that read back to the same bits; a NaN refuses the code.
    #[test]
    fn numbers_are_c_literals_or_refused() {
        let refused = Cell::new(None);
        for x in [0.3, 1e-7, 5.0, 1e21, 2.5e-310, f64::MAX] {
            let (text, _) = number(x, &refused);
            assert!(text.contains('.') || text.contains('e'), "{text}");
            assert_eq!(text.parse::<f64>().ok(), Some(x), "{text}");
        }
        assert_eq!(number(-2.0, &refused).0, "-2.0");
        assert_eq!(number(f64::INFINITY, &refused).0, "HUGE_VAL");
        assert!(refused.get().is_none());
        number(f64::NAN, &refused);
        assert!(refused.get().is_some());
    }
}
