//! The syntax tree of a `.bg` file: what the user wrote, with the span of every name.
//!
//! Nothing here is resolved: names are text. lowering (to come) turns it into a model.

use crate::diagnostic::Span;
use crate::expr::Expr;

/// A name as written, with where it was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ident {
    /// The text of the name.
    pub name: String,
    /// Where it stands in the source.
    pub span: Span,
}

/// An expression whose leaves are names still to be resolved.
pub type AstExpr = Expr<Ident>;

/// A whole file: its statements in source order.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct File {
    /// Every statement that parsed, in order.
    pub statements: Vec<Statement>,
}

/// One statement (one logical line).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Statement {
    /// What it says.
    pub kind: StatementKind,
    /// The whole statement.
    pub span: Span,
}

/// The kinds of statement of the language.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum StatementKind {
    /// `model NAME`
    Model(Ident),
    /// `param NAME = VALUE [unit] "description"`
    Param(ParamDecl),
    /// `input NAME [unit] "description"`
    Input(InputDecl),
    /// `let NAME = EXPR`
    Let(LetDecl),
    /// `KIND NAME body "description"`
    Element(ElementDecl),
    /// `a -> b, c -> d`
    Chain(Chain),
    /// A statement that did not parse (already reported), with what could still be read.
    Unparsed(Unparsed),
}

/// The names a statement that did not parse seems to declare, so that their uses elsewhere
/// are not reported a second time as undefined.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Unparsed {
    /// The first word (`param`, `Se`, `model`…).
    pub first: Option<Ident>,
    /// The second word, when it directly follows the first: the declared name.
    pub name: Option<Ident>,
    /// Junctions written `0:NAME` or `1:NAME`.
    pub junctions: Vec<Ident>,
}

/// A parameter declaration.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ParamDecl {
    /// Its name.
    pub name: Ident,
    /// Its value and the span of the value, if one was written.
    pub value: Option<(f64, Span)>,
    /// Its unit, as free text.
    pub unit: Option<String>,
    /// How far the true value may be from the nominal one, and where that was written.
    pub uncertainty: Option<(Uncertainty, Span)>,
    /// Where `shared` was written: several components read it on purpose.
    pub shared: Option<Span>,
    /// What it is.
    pub description: Option<String>,
}

/// A parameter's uncertainty as written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Uncertainty {
    /// `+- 5%`: a percentage of the nominal value.
    Percent(f64),
    /// `+- 0.015`: in the parameter's unit.
    Absolute(f64),
}

/// A known input signal.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct InputDecl {
    /// Its name.
    pub name: Ident,
    /// Its unit, as free text.
    pub unit: Option<String>,
    /// What it is.
    pub description: Option<String>,
}

/// A named helper expression.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LetDecl {
    /// Its name.
    pub name: Ident,
    /// Its definition.
    pub value: AstExpr,
}

/// An element or detector declaration.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ElementDecl {
    /// The kind as written (`Se`, `R`, `Df`…), checked when lowering.
    pub kind: Ident,
    /// The element's name.
    pub name: Ident,
    /// What follows the name.
    pub body: ElementBody,
    /// `with bias = qb, gain = qg`: the faults it may carry, each `(fault, parameter)`.
    pub faults: Vec<(Ident, Ident)>,
    /// What it is.
    pub description: Option<String>,
}

/// What an element declaration says after the name.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ElementBody {
    /// Nothing.
    None,
    /// `= EXPR`: the value of a source, the modulus of an element.
    Value(AstExpr),
    /// `: VAR = EXPR`: an explicit (possibly nonlinear) law.
    Law(Ident, AstExpr),
    /// `stiffness EXPR`: a C given by its stiffness.
    Stiffness(AstExpr),
    /// `ratio EXPR`: a TF given by its gear ratio.
    Ratio(AstExpr),
    /// `on JUNCTION`: where a detector is attached.
    On(Ident),
}

/// A chain of bonds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chain {
    /// The groups of nodes, in order.
    pub groups: Vec<Vec<NodeRef>>,
    /// The arrows between consecutive groups (`groups.len() - 1` of them).
    pub arrows: Vec<Arrow>,
}

/// A node named in a chain.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct NodeRef {
    /// Its name.
    pub name: Ident,
    /// `Some` when written `0:name` or `1:name`.
    pub junction: Option<JunctionKind>,
    /// The whole reference.
    pub span: Span,
}

/// The two kinds of junction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum JunctionKind {
    /// 0-junction: common effort, flows sum to zero.
    Zero,
    /// 1-junction: common flow, efforts sum to zero.
    One,
}

impl JunctionKind {
    /// `"0"` or `"1"`.
    pub(crate) fn symbol(self) -> &'static str {
        match self {
            JunctionKind::Zero => "0",
            JunctionKind::One => "1",
        }
    }
}

/// An arrow between two groups of a chain.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Arrow {
    /// Whether power flows from the left group to the right one (`->`) or back (`<-`).
    pub forward: bool,
    /// The bond number written on the arrow, with its span.
    pub number: Option<(u32, Span)>,
    /// The arrow.
    pub span: Span,
}
