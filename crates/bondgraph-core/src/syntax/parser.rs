//! From text to [`ast::File`]: each statement parsed by pest, its pairs turned into syntax nodes.

use pest::iterators::{Pair, Pairs};
use pest::pratt_parser::{Assoc, Op, PrattParser};
use pest::Parser as _;
use std::sync::OnceLock;

use super::ast::{self, AstExpr, Ident};
use super::recover;
use super::split;
use crate::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use crate::expr::{BinOp, Expr, Func};

#[allow(missing_docs)]
mod generated {
    /// The pest parser generated from `bg.pest`.
    #[derive(pest_derive::Parser)]
    #[grammar = "syntax/bg.pest"]
    pub(super) struct BgParser;
}
use generated::{BgParser, Rule};

/// Parses a whole file; statements that do not parse are reported and left out.
pub(crate) fn parse(text: &str) -> (ast::File, Diagnostics) {
    let mut file = ast::File::default();
    let mut diagnostics = Diagnostics::default();
    for span in split::statements(text) {
        match parse_statement(&text[span.start..span.end], span.start) {
            Ok(statement) => file.statements.push(statement),
            Err(errors) => {
                errors.into_iter().for_each(|d| diagnostics.push(d));
                let unparsed = recover::names(&text[span.start..span.end], span.start);
                file.statements.push(ast::Statement {
                    kind: ast::StatementKind::Unparsed(unparsed),
                    span,
                });
            }
        }
    }
    (file, diagnostics)
}

/// Parses one statement whose text starts at byte `offset` of its file.
fn parse_statement(text: &str, offset: usize) -> Result<ast::Statement, Vec<Diagnostic>> {
    too_complex(text, offset).map_or(Ok(()), |d| Err(vec![d]))?;
    let mut pairs =
        BgParser::parse(Rule::statement, text).map_err(|e| vec![syntax_error(&e, text, offset)])?;
    let Some(statement) = pairs.next() else {
        return Err(vec![Diagnostic::error(
            Code::Syntax,
            Span::new(offset, offset + text.len()),
            "empty statement",
        )]);
    };
    let mut builder = Builder {
        offset,
        text,
        errors: Vec::new(),
    };
    let kind = statement
        .into_inner()
        .find(|p| p.as_rule() != Rule::EOI)
        .map(|p| builder.statement(p));
    match kind {
        Some(kind) if builder.errors.is_empty() => Ok(ast::Statement {
            kind,
            span: Span::new(offset, offset + text.len()),
        }),
        _ => Err(builder.errors),
    }
}

/// Parses an expression on its own (a scenario's right-hand side), whose text starts at byte
/// `offset` of its file.
pub fn parse_expr(text: &str, offset: usize) -> Result<AstExpr, Vec<Diagnostic>> {
    too_complex(text, offset).map_or(Ok(()), |d| Err(vec![d]))?;
    let mut pairs =
        BgParser::parse(Rule::lone_expr, text).map_err(|e| vec![syntax_error(&e, text, offset)])?;
    let Some(pair) = pairs
        .next()
        .and_then(|p| p.into_inner().find(|p| p.as_rule() == Rule::expr))
    else {
        return Err(vec![Diagnostic::error(
            Code::Syntax,
            Span::new(offset, offset + text.len()),
            "expected an expression",
        )]);
    };
    let mut builder = Builder {
        offset,
        text,
        errors: Vec::new(),
    };
    let expr = builder.expr(pair);
    if builder.errors.is_empty() {
        Ok(expr)
    } else {
        Err(builder.errors)
    }
}

/// Most operators in one statement; also bounds the depth of every expression tree.
pub(crate) const MAX_OPERATORS: usize = 1000;
/// Deepest nesting of parentheses.
pub(crate) const MAX_NESTING: usize = 64;

/// Rejects a statement whose expression would be deeper than the recursive stages after the
/// parser (and the parser itself) can take without exhausting the stack. No model of a real
/// machine comes near these limits; a corrupted or generated file can.
fn too_complex(text: &str, offset: usize) -> Option<Diagnostic> {
    let bytes = text.as_bytes();
    let (mut operators, mut depth) = (0usize, 0usize);
    let mut in_text = false;
    let mut in_comment = false;
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'\n' => (in_text, in_comment) = (false, false),
            _ if in_comment => {}
            b'"' => in_text = !in_text,
            _ if in_text => {}
            b'#' => in_comment = true,
            b'(' => {
                depth += 1;
                operators += 1;
            }
            b')' => depth = depth.saturating_sub(1),
            b'+' | b'*' | b'/' | b'^' | b',' => operators += 1,
            // A minus that is not part of an arrow (`->`, `<-`, `-[3]->`, `<-[3]-`).
            b'-' => {
                let next = bytes.get(i + 1).copied();
                let previous = i.checked_sub(1).map(|j| bytes[j]);
                if !matches!(next, Some(b'>' | b'[')) && !matches!(previous, Some(b'<' | b']')) {
                    operators += 1;
                }
            }
            _ => {}
        }
        let span = Span::new(i, i + 1).shifted(offset);
        if depth > MAX_NESTING {
            return Some(
                Diagnostic::error(Code::Syntax, span, "parentheses nested too deep")
                    .with_label(format!(
                        "expected at most {MAX_NESTING} levels of parentheses"
                    ))
                    .with_help("split the expression with `let` definitions"),
            );
        }
        if operators > MAX_OPERATORS {
            return Some(
                Diagnostic::error(Code::Syntax, span, "too many operators in one statement")
                    .with_label(format!(
                        "expected at most {MAX_OPERATORS} operators per statement"
                    ))
                    .with_help("split the expression with `let` definitions"),
            );
        }
    }
    None
}

/// Turns pairs into syntax nodes, collecting the errors the grammar cannot express.
struct Builder<'t> {
    offset: usize,
    /// The statement's text, which starts at byte `offset` of its file.
    text: &'t str,
    errors: Vec<Diagnostic>,
}

impl Builder<'_> {
    fn span(&self, pair: &Pair<'_, Rule>) -> Span {
        let s = pair.as_span();
        Span::new(s.start(), s.end()).shifted(self.offset)
    }

    fn ident(&self, pair: Pair<'_, Rule>) -> Ident {
        Ident {
            name: pair.as_str().to_string(),
            span: self.span(&pair),
        }
    }

    fn statement(&mut self, pair: Pair<'_, Rule>) -> ast::StatementKind {
        let rule = pair.as_rule();
        let mut inner = pair.into_inner();
        match rule {
            Rule::model_decl => {
                let name = self.ident(nth(&mut inner, Rule::ident));
                ast::StatementKind::Model(name)
            }
            Rule::param_decl => ast::StatementKind::Param(self.param(inner)),
            Rule::input_decl => {
                let name = self.ident(nth(&mut inner, Rule::ident));
                let (unit, description) = unit_and_description(inner);
                ast::StatementKind::Input(ast::InputDecl {
                    name,
                    unit,
                    description,
                })
            }
            Rule::let_decl => {
                let name = self.ident(nth(&mut inner, Rule::ident));
                let value = self.expr(nth(&mut inner, Rule::expr));
                ast::StatementKind::Let(ast::LetDecl { name, value })
            }
            Rule::element_decl => ast::StatementKind::Element(self.element(inner)),
            _ => ast::StatementKind::Chain(self.chain(inner)),
        }
    }

    fn param(&mut self, inner: Pairs<'_, Rule>) -> ast::ParamDecl {
        let mut name = None;
        let mut value = None;
        let mut unit = None;
        let mut uncertainty = None;
        let mut shared = None;
        let mut description = None;
        for p in inner {
            match p.as_rule() {
                Rule::ident => name = Some(self.ident(p)),
                Rule::param_value => value = self.param_value(p),
                Rule::unit => unit = Some(inner_text(p)),
                Rule::uncertainty => uncertainty = self.uncertainty(p),
                Rule::kw_shared => shared = Some(self.span(&p)),
                Rule::description => description = Some(inner_text(p)),
                _ => {}
            }
        }
        ast::ParamDecl {
            name: name.unwrap_or_else(|| Ident {
                name: String::new(),
                span: Span::new(self.offset, self.offset),
            }),
            value,
            unit,
            uncertainty,
            shared,
            description,
        }
    }

    fn uncertainty(&mut self, pair: Pair<'_, Rule>) -> Option<(ast::Uncertainty, Span)> {
        let span = self.span(&pair);
        let mut inner = pair.into_inner();
        let number = inner.find(|p| p.as_rule() == Rule::number)?;
        let value = self.number(&number)?;
        let percent = inner.any(|p| p.as_rule() == Rule::percent);
        Some((
            if percent {
                ast::Uncertainty::Percent(value)
            } else {
                ast::Uncertainty::Absolute(value)
            },
            span,
        ))
    }

    fn param_value(&mut self, pair: Pair<'_, Rule>) -> Option<(f64, Span)> {
        let span = self.span(&pair);
        let negative = pair
            .clone()
            .into_inner()
            .any(|p| p.as_rule() == Rule::sign && p.as_str() == "-");
        let number = pair.into_inner().find(|p| p.as_rule() == Rule::number)?;
        let value = self.number(&number)?;
        Some((if negative { -value } else { value }, span))
    }

    fn number(&mut self, pair: &Pair<'_, Rule>) -> Option<f64> {
        match pair.as_str().parse::<f64>() {
            Ok(x) if x.is_finite() => Some(x),
            _ => {
                self.errors.push(
                    Diagnostic::error(Code::Syntax, self.span(pair), "number out of range")
                        .with_label("expected a finite number"),
                );
                None
            }
        }
    }

    fn element(&mut self, mut inner: Pairs<'_, Rule>) -> ast::ElementDecl {
        let kind = self.ident(nth(&mut inner, Rule::ident));
        let name = self.ident(nth(&mut inner, Rule::ident));
        let mut body = ast::ElementBody::None;
        let mut description = None;
        let mut faults = Vec::new();
        for p in inner {
            let rule = p.as_rule();
            if rule == Rule::description {
                description = Some(inner_text(p));
                continue;
            }
            if rule == Rule::with_clause {
                faults = self.faults(p.into_inner());
                continue;
            }
            let mut parts = p.into_inner();
            body = match rule {
                Rule::value_body => ast::ElementBody::Value(self.expr(nth(&mut parts, Rule::expr))),
                Rule::law_body => {
                    let var = self.ident(nth(&mut parts, Rule::ident));
                    ast::ElementBody::Law(var, self.expr(nth(&mut parts, Rule::expr)))
                }
                Rule::stiffness_body => {
                    ast::ElementBody::Stiffness(self.expr(nth(&mut parts, Rule::expr)))
                }
                Rule::ratio_body => ast::ElementBody::Ratio(self.expr(nth(&mut parts, Rule::expr))),
                _ => ast::ElementBody::On(self.ident(nth(&mut parts, Rule::ident))),
            };
        }
        ast::ElementDecl {
            kind,
            name,
            body,
            faults,
            description,
        }
    }

    /// The `fault = parameter` pairs of a `with` clause.
    fn faults(&mut self, inner: Pairs<'_, Rule>) -> Vec<(ast::Ident, ast::Ident)> {
        inner
            .filter(|p| p.as_rule() == Rule::fault_item)
            .map(|p| {
                let mut parts = p.into_inner();
                let fault = self.ident(nth(&mut parts, Rule::ident));
                (fault, self.ident(nth(&mut parts, Rule::ident)))
            })
            .collect()
    }

    fn chain(&mut self, inner: Pairs<'_, Rule>) -> ast::Chain {
        let mut chain = ast::Chain {
            groups: Vec::new(),
            arrows: Vec::new(),
        };
        for p in inner {
            match p.as_rule() {
                Rule::group => {
                    let group = p.into_inner().map(|n| self.node_ref(n)).collect();
                    chain.groups.push(group);
                }
                rule => {
                    let span = self.span(&p);
                    let number = p.into_inner().next().and_then(|n| {
                        let s = self.span(&n);
                        match n.as_str().parse::<u32>() {
                            Ok(k) if k > 0 => Some((k, s)),
                            _ => {
                                self.errors.push(
                                    Diagnostic::error(Code::BondNumber, s, "bad bond number")
                                        .with_label("expected a number from 1 to 4294967295"),
                                );
                                None
                            }
                        }
                    });
                    chain.arrows.push(ast::Arrow {
                        forward: rule == Rule::arrow_forward,
                        number,
                        span,
                    });
                }
            }
        }
        chain
    }

    fn node_ref(&mut self, pair: Pair<'_, Rule>) -> ast::NodeRef {
        let span = self.span(&pair);
        let Some(first) = pair.into_inner().next() else {
            return ast::NodeRef {
                name: Ident {
                    name: String::new(),
                    span,
                },
                junction: None,
                span,
            };
        };
        if first.as_rule() == Rule::junction {
            let mut parts = first.into_inner();
            let kind = match nth(&mut parts, Rule::junction_kind).as_str() {
                "0" => ast::JunctionKind::Zero,
                _ => ast::JunctionKind::One,
            };
            let name = self.ident(nth(&mut parts, Rule::ident));
            ast::NodeRef {
                name,
                junction: Some(kind),
                span,
            }
        } else {
            ast::NodeRef {
                name: self.ident(first),
                junction: None,
                span,
            }
        }
    }

    fn expr(&mut self, pair: Pair<'_, Rule>) -> AstExpr {
        let pratt = pratt();
        self.expr_pairs(pair.into_inner(), pratt)
    }

    fn expr_pairs(&mut self, pairs: Pairs<'_, Rule>, pratt: &PrattParser<Rule>) -> AstExpr {
        // The closures below all need `self`; a RefCell lets them share it for one parse.
        // Each node carries its span, so that a value the language refuses is located.
        let this = std::cell::RefCell::new(self);
        let (expr, _) = pratt
            .map_primary(|p| {
                let span = this.borrow().span(&p);
                let text = p.as_str().to_string();
                let e = this.borrow_mut().primary(p, pratt);
                this.borrow_mut().finite(e, span, &text)
            })
            .map_prefix(|op, (x, span)| {
                let span = Span::new(this.borrow().span(&op).start, span.end);
                match op.as_rule() {
                    Rule::neg => (Expr::Neg(Box::new(x)), span),
                    _ => (x, span),
                }
            })
            .map_infix(|(a, left), op, (b, right)| {
                let op = match op.as_rule() {
                    Rule::add => BinOp::Add,
                    Rule::sub => BinOp::Sub,
                    Rule::mul => BinOp::Mul,
                    Rule::div => BinOp::Div,
                    _ => BinOp::Pow,
                };
                let span = Span::new(left.start, right.end);
                let mut this = this.borrow_mut();
                if op == BinOp::Div && identically_zero(&b) {
                    this.errors.push(
                        Diagnostic::error(Code::BadValue, right, "a division by zero")
                            .with_label("this denominator is 0 whatever its signals' values")
                            .with_help(
                                "the language has no infinite value: divide by what is not zero",
                            ),
                    );
                    return (Expr::Num(1.0), span);
                }
                let text = this.text_of(span);
                this.finite(Expr::binary(op, a, b), span, &text)
            })
            .parse(pairs);
        expr
    }

    /// The model's text under `span` (empty if the builder does not hold it).
    fn text_of(&self, span: Span) -> String {
        let start = span.start.saturating_sub(self.offset);
        let end = span.end.saturating_sub(self.offset);
        self.text.get(start..end).unwrap_or("").trim().to_string()
    }

    /// `e` as it is, unless it reads no signal and its value is not a finite number (`log(0)`,
    /// `0^-1`, `exp(1000)`): then an error at `span`, and 1 in its place so that what holds
    /// it is not refused again.
    fn finite(&mut self, e: AstExpr, span: Span, text: &str) -> (AstExpr, Span) {
        match constant(&e) {
            Some(v) if !v.is_finite() => {
                self.errors.push(
                    Diagnostic::error(
                        Code::BadValue,
                        span,
                        format!("`{text}` is not a finite number"),
                    )
                    .with_label(format!("this is {v}"))
                    .with_help("the language has no infinite or undefined value"),
                );
                (Expr::Num(1.0), span)
            }
            _ => (e, span),
        }
    }

    fn primary(&mut self, pair: Pair<'_, Rule>, pratt: &PrattParser<Rule>) -> AstExpr {
        match pair.as_rule() {
            Rule::number => Expr::Num(self.number(&pair).unwrap_or(0.0)),
            Rule::ident => Expr::Leaf(self.ident(pair)),
            Rule::expr => self.expr_pairs(pair.into_inner(), pratt),
            _ => self.call(pair, pratt),
        }
    }

    fn call(&mut self, pair: Pair<'_, Rule>, pratt: &PrattParser<Rule>) -> AstExpr {
        let span = self.span(&pair);
        let mut inner = pair.into_inner();
        let name = self.ident(nth(&mut inner, Rule::ident));
        let args: Vec<Pair<'_, Rule>> = inner.collect();
        match name.name.as_str() {
            "der" => self.der(&name, span, args, pratt),
            "int" => match <[_; 1]>::try_from(args) {
                Ok([x]) => Expr::Int(Box::new(self.expr_pairs(x.into_inner(), pratt))),
                Err(args) => self.arity_error(&name, span, args.len(), "1"),
            },
            _ => match Func::from_name(&name.name) {
                Some(func) if func.arity() == args.len() => {
                    let args = args
                        .into_iter()
                        .map(|a| self.expr_pairs(a.into_inner(), pratt))
                        .collect();
                    Expr::Call(func, args)
                }
                Some(func) => self.arity_error(&name, span, args.len(), &func.arity().to_string()),
                None => {
                    let known: Vec<&str> = Func::ALL.iter().map(|f| f.name()).collect();
                    self.errors.push(
                        Diagnostic::error(
                            Code::BadCall,
                            name.span,
                            format!("unknown function `{}`", name.name),
                        )
                        .with_label("not a function of the language")
                        .with_help(format!(
                            "the functions are {}, der and int",
                            known.join(", ")
                        )),
                    );
                    Expr::Num(0.0)
                }
            },
        }
    }

    fn der(
        &mut self,
        name: &Ident,
        span: Span,
        args: Vec<Pair<'_, Rule>>,
        pratt: &PrattParser<Rule>,
    ) -> AstExpr {
        let mut args = args.into_iter();
        let (Some(x), order, None) = (args.next(), args.next(), args.next()) else {
            return self.arity_error(name, span, 0, "1 or 2");
        };
        let n = match order {
            None => 1,
            Some(o) => {
                let s = self.span(&o);
                match o.as_str().trim().parse::<u32>() {
                    Ok(n @ 1..=16) => n,
                    _ => {
                        self.errors.push(
                            Diagnostic::error(
                                Code::BadCall,
                                s,
                                "the order of a derivative must be a whole number",
                            )
                            .with_label("expected an integer from 1 to 16"),
                        );
                        1
                    }
                }
            }
        };
        Expr::Der(Box::new(self.expr_pairs(x.into_inner(), pratt)), n)
    }

    fn arity_error(&mut self, name: &Ident, span: Span, got: usize, want: &str) -> AstExpr {
        self.errors.push(
            Diagnostic::error(
                Code::BadCall,
                span,
                format!(
                    "`{}` called with {got} argument{}",
                    name.name,
                    if got == 1 { "" } else { "s" }
                ),
            )
            .with_label(format!(
                "expected {want} argument{}",
                if want == "1" { "" } else { "s" }
            )),
        );
        Expr::Num(0.0)
    }
}

/// The value of an expression that reads no signal (numbers and functions of them).
fn constant(e: &AstExpr) -> Option<f64> {
    Some(match e {
        Expr::Num(x) => *x,
        Expr::Leaf(_) | Expr::Der(..) | Expr::Int(_) => return None,
        Expr::Neg(a) => -constant(a)?,
        Expr::Binary(op, a, b) => op.apply(constant(a)?, constant(b)?),
        Expr::Call(f, args) => {
            let args: Option<Vec<f64>> = args.iter().map(constant).collect();
            f.apply(&args?)
        }
    })
}

/// Whether `e` is 0 whatever its names stand for (`0`, `fe - fe`, `(t - t)*x`): 0 at three
/// assignments of values to its names, none of them special. A function of the names that
/// is not identically 0 vanishes at all three only by a coincidence of measure zero.
fn identically_zero(e: &AstExpr) -> bool {
    (1..=3u64).all(|k| at(e, k) == Some(0.0))
}

/// `e` with each name worth a value drawn from its name and `k`, in [0.7, 1.9]; `der` and
/// `int` of an expression as the expression.
fn at(e: &AstExpr, k: u64) -> Option<f64> {
    Some(match e {
        Expr::Num(x) => *x,
        Expr::Leaf(id) => {
            let h = (id.name.bytes()).fold(0xcbf2_9ce4_8422_2325u64 ^ k, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            });
            0.7 + 1.2 * ((h >> 11) as f64 / (1u64 << 53) as f64)
        }
        Expr::Der(a, _) | Expr::Int(a) => at(a, k)?,
        Expr::Neg(a) => -at(a, k)?,
        Expr::Binary(op, a, b) => op.apply(at(a, k)?, at(b, k)?),
        Expr::Call(f, args) => {
            let args: Option<Vec<f64>> = args.iter().map(|a| at(a, k)).collect();
            f.apply(&args?)
        }
    })
}

fn pratt() -> &'static PrattParser<Rule> {
    static PRATT: OnceLock<PrattParser<Rule>> = OnceLock::new();
    PRATT.get_or_init(|| {
        // Lowest precedence first. Prefix minus sits below `^`, so `-x^2` is `-(x^2)`.
        PrattParser::new()
            .op(Op::infix(Rule::add, Assoc::Left) | Op::infix(Rule::sub, Assoc::Left))
            .op(Op::infix(Rule::mul, Assoc::Left) | Op::infix(Rule::div, Assoc::Left))
            .op(Op::prefix(Rule::neg) | Op::prefix(Rule::pos))
            .op(Op::infix(Rule::pow, Assoc::Right))
    })
}

/// The next pair, which the grammar guarantees is a `rule`.
fn nth<'i>(pairs: &mut Pairs<'i, Rule>, rule: Rule) -> Pair<'i, Rule> {
    let found = pairs.find(|p| p.as_rule() == rule);
    // The grammar makes this pair mandatory; a missing one is a bug in this file, not in input.
    found.unwrap_or_else(|| panic!("grammar guarantees a {rule:?} here"))
}

fn inner_text(pair: Pair<'_, Rule>) -> String {
    pair.into_inner()
        .next()
        .map_or_else(String::new, |p| p.as_str().trim().to_string())
}

fn unit_and_description(inner: Pairs<'_, Rule>) -> (Option<String>, Option<String>) {
    let mut unit = None;
    let mut description = None;
    for p in inner {
        match p.as_rule() {
            Rule::unit => unit = Some(inner_text(p)),
            Rule::description => description = Some(inner_text(p)),
            _ => {}
        }
    }
    (unit, description)
}

/// A pest error as a diagnostic that names what was expected, in the language's own words.
fn syntax_error(error: &pest::error::Error<Rule>, text: &str, offset: usize) -> Diagnostic {
    let pos = match error.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((s, _)) => s,
    };
    let end = next_token_end(text, pos);
    let found = text.get(pos..end).unwrap_or("");
    // At the end of a statement there is nothing to underline: point at its last character.
    let span = if found.is_empty() {
        let last = text
            .get(..pos)
            .and_then(|t| t.trim_end().char_indices().last());
        last.map_or(Span::new(pos, pos), |(i, c)| Span::new(i, i + c.len_utf8()))
    } else {
        Span::new(pos, end)
    }
    .shifted(offset);
    let expected = match &error.variant {
        pest::error::ErrorVariant::ParsingError { positives, .. } => describe(positives),
        pest::error::ErrorVariant::CustomError { message } => message.clone(),
    };
    let message = if found.is_empty() {
        "unexpected end of statement".to_string()
    } else {
        format!("unexpected `{found}`")
    };
    let d =
        Diagnostic::error(Code::Syntax, span, message).with_label(format!("expected {expected}"));
    let open = text.matches('(').count();
    if found.is_empty() && open > text.matches(')').count() {
        d.with_help("a `(` is not closed")
    } else {
        d
    }
}

/// The end of the token starting at `pos`, so the error underlines a word, not one byte.
fn next_token_end(text: &str, pos: usize) -> usize {
    let rest = text.get(pos..).unwrap_or("");
    let mut chars = rest.char_indices();
    let Some((_, first)) = chars.next() else {
        return pos;
    };
    let is_word = |c: char| c.is_alphanumeric() || c == '_' || c == '.';
    if !is_word(first) {
        return pos + first.len_utf8();
    }
    pos + chars
        .find(|&(_, c)| !is_word(c))
        .map_or(rest.len(), |(i, _)| i)
}

/// "a or b": the expected tokens, named as a user would name them.
fn describe(rules: &[Rule]) -> String {
    let mut names: Vec<&str> = rules.iter().filter_map(|r| rule_name(*r)).collect();
    names.sort_unstable();
    names.dedup();
    match names.as_slice() {
        [] => "something else".to_string(),
        [one] => (*one).to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

fn rule_name(rule: Rule) -> Option<&'static str> {
    Some(match rule {
        Rule::statement | Rule::element_decl | Rule::chain => "a statement",
        Rule::ident | Rule::keyword => "a name",
        Rule::kw_model => "`model`",
        Rule::kw_param => "`param`",
        Rule::kw_shared => "`shared`",
        Rule::kw_with => "`with`",
        Rule::with_clause => "`with FAULT = PARAMETER`",
        Rule::fault_item => "`FAULT = PARAMETER`",
        Rule::kw_input => "`input`",
        Rule::kw_let => "`let`",
        Rule::kw_on => "`on`",
        Rule::kw_stiffness => "`stiffness`",
        Rule::kw_ratio => "`ratio`",
        Rule::param_value | Rule::number | Rule::sign => "a number",
        Rule::unit => "a unit in brackets like `[Ohm]`",
        Rule::description => "a description in double quotes",
        Rule::uncertainty | Rule::percent => "an uncertainty like `+- 5%` or `+- 0.01`",
        Rule::value_body | Rule::law_body | Rule::stiffness_body | Rule::ratio_body => {
            "`= value`, `: law`, `stiffness`, `ratio`"
        }
        Rule::on_body => "`on`",
        Rule::group | Rule::node_ref | Rule::junction => "a node (a name, `0:name` or `1:name`)",
        Rule::junction_kind => "`0` or `1`",
        Rule::arrow_forward | Rule::arrow_back => "an arrow (`->` or `<-`)",
        Rule::bond_number => "a bond number",
        Rule::expr | Rule::call => "an expression",
        Rule::add | Rule::sub | Rule::mul | Rule::div | Rule::pow => "an operator",
        Rule::neg | Rule::pos => "an expression",
        Rule::EOI => "the end of the statement",
        Rule::lone_expr => "an expression",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_at_the_limits_parse_and_beyond_them_are_refused() {
        // Run where tests run: a 2 MiB thread stack.
        let statement = |body: String| format!("let x = {body}");
        let power = statement(format!("a{}", "^a".repeat(MAX_OPERATORS)));
        let minus = statement(format!("{}a", "-".repeat(MAX_OPERATORS)));
        let sum = statement(format!("a{}", "+a".repeat(MAX_OPERATORS)));
        let parens = statement(format!(
            "{}a{}",
            "(".repeat(MAX_NESTING),
            ")".repeat(MAX_NESTING)
        ));
        for text in [&power, &minus, &sum, &parens] {
            let (file, diagnostics) = parse(text);
            assert!(diagnostics.is_empty(), "{diagnostics:?}");
            let mut leaves = 0;
            for s in &file.statements {
                if let ast::StatementKind::Let(l) = &s.kind {
                    l.value.for_each_leaf(&mut |_| leaves += 1);
                }
            }
            assert!(leaves >= 1);
        }
        for text in [
            format!("{power}^a"),
            format!("-{minus}"),
            format!("let x = ({})", &parens[8..]),
        ] {
            let (_, diagnostics) = parse(&text);
            assert_eq!(diagnostics.len(), 1, "{diagnostics:?}");
        }
    }
    use crate::syntax::ast::{ElementBody, StatementKind};

    fn one(text: &str) -> StatementKind {
        let (file, diags) = parse(text);
        assert!(diags.is_empty(), "{diags:?}");
        file.statements.into_iter().next().unwrap().kind
    }

    fn show(e: &AstExpr) -> String {
        let mut s = String::new();
        e.write_with(&mut s, &|i: &Ident| i.name.clone()).unwrap();
        s
    }

    fn value_of(text: &str) -> String {
        match one(text) {
            StatementKind::Let(l) => show(&l.value),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn precedence_follows_mathematics() {
        assert_eq!(value_of("let a = 1 + 2 * 3"), "1 + 2 * 3");
        assert_eq!(value_of("let a = (1 + 2) * 3"), "(1 + 2) * 3");
        assert_eq!(value_of("let a = -x^2"), "-x ^ 2");
        assert_eq!(value_of("let a = x^y^z"), "x ^ y ^ z");
        assert_eq!(value_of("let a = a - b - c"), "a - b - c");
        assert_eq!(value_of("let a = 2.5e-3 / x"), "0.0025 / x");
        assert_eq!(
            value_of("let w = -4*K*j0*(1 - exp(-gamma*z))/(1 + exp(-gamma*z))"),
            "-4 * K * j0 * (1 - exp(-gamma * z)) / (1 + exp(-gamma * z))"
        );
        assert_eq!(
            value_of("let d = der(y, 2) + int(y) + der(y)"),
            "der(y, 2) + int(y) + der(y)"
        );
    }

    #[test]
    fn spans_point_into_the_file() {
        let text = "model m\nparam Re = 0.3 [Ohm] \"armature resistance\"\n";
        let (file, _) = parse(text);
        let StatementKind::Param(p) = &file.statements[1].kind else {
            panic!()
        };
        assert_eq!(&text[p.name.span.start..p.name.span.end], "Re");
        assert_eq!(p.value.map(|v| v.0), Some(0.3));
        assert_eq!(p.unit.as_deref(), Some("Ohm"));
        assert_eq!(p.description.as_deref(), Some("armature resistance"));
    }

    #[test]
    fn element_bodies() {
        match one("C link stiffness K \"spring\"") {
            StatementKind::Element(e) => {
                assert_eq!(e.kind.name, "C");
                assert!(matches!(e.body, ElementBody::Stiffness(_)));
                assert_eq!(e.description.as_deref(), Some("spring"));
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            one("R o : f = k*sqrt(abs(e))"),
            StatementKind::Element(ast::ElementDecl {
                body: ElementBody::Law(..),
                ..
            })
        ));
        assert!(matches!(
            one("Df y1 on shaft"),
            StatementKind::Element(ast::ElementDecl {
                body: ElementBody::On(..),
                ..
            })
        ));
    }

    #[test]
    fn chains_with_fan_out_numbers_and_back_arrows() {
        let StatementKind::Chain(c) = one("U -[1]-> 1:elec ->\n  Rm, Lm <- x") else {
            panic!()
        };
        assert_eq!(c.groups.len(), 4);
        assert_eq!(c.groups[2].len(), 2);
        assert_eq!(c.groups[1][0].junction, Some(ast::JunctionKind::One));
        assert_eq!(c.arrows[0].number.map(|n| n.0), Some(1));
        assert!(c.arrows[0].forward);
        assert!(!c.arrows[2].forward);
    }

    #[test]
    fn every_bad_statement_is_reported() {
        let (file, diags) = parse("model m\nparam = 3\nR r = (1\nR ok = 2\nlet x = foo(1)\n");
        // The bad statements stay in the file as `Unparsed`, with the names they declare.
        let parsed = file
            .statements
            .iter()
            .filter(|s| !matches!(s.kind, ast::StatementKind::Unparsed(_)))
            .count();
        assert_eq!((parsed, file.statements.len()), (2, 5));
        assert_eq!(diags.len(), 3);
        let first = diags.iter().next().unwrap();
        assert_eq!(first.code, Code::Syntax);
        assert!(first.label.contains("a name"), "{}", first.label);
    }
}
