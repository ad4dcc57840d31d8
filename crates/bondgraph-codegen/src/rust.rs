//! Residual code: the items a user's crate compiles to evaluate the ARRs on a bench.
//!
//! [`tokens`] builds them as a token stream (what `bond_graph!` returns), [`emit`] formats
//! them with prettyplease (what `bgc --emit rust` writes). The file is items only, no inner
//! attributes and no wrapping `mod`, so that it can be a module file or `include!`d. It calls
//! the `bondgraph` runtime crate for the FSM decision and the estimators.
//!
//! Every expression node that is used more than once (across all ARRs and the auxiliary
//! signals they read) is computed once, as a `let`: the bench's `exp(gamma (N y2_int −
//! y1_int))` is evaluated once per call.

use std::cell::Cell;
use std::collections::HashMap;
use std::fmt;

use bondgraph_core::program::{Code, Evaluation, Fill, Leaf, Program, Slot, Source};
use bondgraph_core::{BinOp, Compiled, Func, Handle, Node, Printer, Realisation, ResidualForm};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

use crate::names;
use crate::sharing::{bindings, Binding};
use crate::signals::{fields, Field};

/// Why residual code was not written: something its program holds that Rust code cannot
/// compute (it would have stood as a NaN in the code).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unwritable(pub(crate) &'static str);

impl fmt::Display for Unwritable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

impl std::error::Error for Unwritable {}

/// The model's items, formatted, with a header naming the model.
pub fn emit(c: &Compiled) -> Result<String, Unwritable> {
    let tokens = tokens(c)?;
    let file = match syn::parse2::<syn::File>(tokens.clone()) {
        Ok(file) => prettyplease::unparse(&file),
        // The generator writes only what parses; if not, the tokens as they are.
        Err(_) => tokens.to_string(),
    };
    Ok(format!(
        "// Residual code for the model `{}` ({}), written by bgc.\n// It needs the `bondgraph` runtime crate.\n\n{file}",
        c.name, c.file_name
    ))
}

/// Rust's keywords, strict and reserved (2021 edition): a model name among them is written
/// raw.
const KEYWORDS: [&str; 51] = [
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for",
    "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
    "self", "Self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use", "where",
    "while", "async", "await", "dyn", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try",
];

/// A Rust identifier for a model name (letters, digits and `_`, as the model language
/// allows): itself, raw when it is a keyword (`r#type`), or with a trailing `_` when it
/// cannot be raw (`self_`, `crate_`).
pub fn ident(name: &str) -> Ident {
    let cannot_be_raw = ["self", "Self", "super", "crate", "_"];
    if cannot_be_raw.contains(&name) {
        format_ident!("{}_", name)
    } else if KEYWORDS.contains(&name) {
        Ident::new_raw(name, Span::call_site())
    } else {
        Ident::new(name, Span::call_site())
    }
}

/// Binding strengths of Rust expressions as the lowering writes them.
const SUM: u8 = 1;
const PRODUCT: u8 = 2;
const UNARY: u8 = 3;
const ATOM: u8 = 5;

/// Where program code is printed: what time and the copy's leaves are called there.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Place {
    /// `residuals` and `bounds`: slots as `s.NAME`; they read no time.
    Residuals,
    /// `push`, integrating a nonlinear expression at the estimates' instant `at`.
    Push,
    /// `copy_rates`: states `x[k]`, inputs `u[j]`, time `t`.
    Copy,
}

/// Prints program code as Rust, with shared nodes bound once.
struct Lowering<'p> {
    c: &'p Compiled,
    program: &'p Program,
    place: Place,
    /// Each slot's field.
    field: HashMap<Handle<Slot>, Ident>,
    /// Nodes already bound to a `let`.
    bound: HashMap<Code, Ident>,
    /// Set when the code met something Rust cannot compute: nothing is written then.
    refused: &'p Cell<Option<Unwritable>>,
}

impl<'p> Lowering<'p> {
    fn new(
        c: &'p Compiled,
        program: &'p Program,
        fields: &[Field],
        refused: &'p Cell<Option<Unwritable>>,
        place: Place,
    ) -> Self {
        Lowering {
            c,
            program,
            refused,
            place,
            field: fields.iter().map(|f| (f.slot, ident(&f.name))).collect(),
            bound: HashMap::new(),
        }
    }

    /// The same lowering with nothing bound yet: for code in a block of its own.
    fn fresh(&self) -> Lowering<'p> {
        Lowering {
            c: self.c,
            program: self.program,
            place: self.place,
            field: self.field.clone(),
            bound: HashMap::new(),
            refused: self.refused,
        }
    }

    fn wrap(ts: TokenStream, prec: u8, needed: u8) -> TokenStream {
        if prec < needed {
            quote!((#ts))
        } else {
            ts
        }
    }

    /// `e` as Rust, with its binding strength.
    fn expr(&self, e: Code) -> (TokenStream, u8) {
        if let Some(name) = self.bound.get(&e) {
            return (quote!(#name), ATOM);
        }
        match self.program.code.node(e) {
            Node::Num(bits) => number(f64::from_bits(bits), self.refused),
            Node::Leaf(l) => (self.leaf(l), ATOM),
            Node::Neg(a) => {
                let a = self.operand(a, UNARY);
                (quote!(-#a), UNARY)
            }
            Node::Binary(BinOp::Pow, a, b) => {
                let base = self.receiver(a);
                match self.program.code.node(b) {
                    Node::Num(bits)
                        if f64::from_bits(bits).fract() == 0.0
                            && f64::from_bits(bits).abs() < 64.0 =>
                    {
                        let n = Literal::i32_unsuffixed(f64::from_bits(bits) as i32);
                        (quote!(#base.powi(#n)), ATOM)
                    }
                    _ => {
                        let (exponent, _) = self.expr(b);
                        (quote!(#base.powf(#exponent)), ATOM)
                    }
                }
            }
            Node::Binary(op, a, b) => {
                let (prec, right) = match op {
                    BinOp::Add => (SUM, SUM),
                    BinOp::Sub => (SUM, PRODUCT),
                    BinOp::Mul => (PRODUCT, PRODUCT),
                    _ => (PRODUCT, UNARY),
                };
                let left = self.operand(a, prec);
                let right = self.operand(b, right);
                let ts = match op {
                    BinOp::Add => quote!(#left + #right),
                    BinOp::Sub => quote!(#left - #right),
                    BinOp::Mul => quote!(#left * #right),
                    _ => quote!(#left / #right),
                };
                (ts, prec)
            }
            Node::Call1(f, a) => {
                let x = self.receiver(a);
                let ts = match f {
                    Func::Exp => quote!(#x.exp()),
                    Func::Log => quote!(#x.ln()),
                    Func::Sqrt => quote!(#x.sqrt()),
                    Func::Abs => quote!(#x.abs()),
                    Func::Sin => quote!(#x.sin()),
                    Func::Cos => quote!(#x.cos()),
                    Func::Tan => quote!(#x.tan()),
                    Func::Tanh => quote!(#x.tanh()),
                    Func::Atan => quote!(#x.atan()),
                    Func::Atanh => quote!(#x.atanh()),
                    _ => {
                        let (arg, _) = self.expr(a);
                        quote!(::bondgraph::sign(#arg))
                    }
                };
                (ts, ATOM)
            }
            Node::Call2(f, a, b) => {
                let x = self.receiver(a);
                let (y, _) = self.expr(b);
                let ts = match f {
                    Func::Min => quote!(#x.min(#y)),
                    _ => quote!(#x.max(#y)),
                };
                (ts, ATOM)
            }
            // The program holds no integral (each is a slot or a state).
            Node::Int(_) => self.refuse("an integral the residual program did not make a slot"),
        }
    }

    fn operand(&self, e: Code, needed: u8) -> TokenStream {
        let (ts, prec) = self.expr(e);
        Self::wrap(ts, prec, needed)
    }

    /// `e` as the receiver of a method call: a number needs its type (`2.0_f64.exp()`).
    fn receiver(&self, e: Code) -> TokenStream {
        match self.program.code.node(e) {
            Node::Num(bits) if !self.bound.contains_key(&e) && f64::from_bits(bits).is_finite() => {
                let lit = Literal::f64_suffixed(f64::from_bits(bits));
                quote!((#lit))
            }
            _ => self.operand(e, ATOM),
        }
    }

    fn leaf(&self, l: Leaf) -> TokenStream {
        match (l, self.place) {
            (Leaf::Slot(h), _) => match self.field.get(&h) {
                Some(name) => quote!(s.#name),
                None => {
                    self.refuse("a value the residuals read with no field to read it from")
                        .0
                }
            },
            (Leaf::Parameter(p), _) => {
                let name = ident(&self.c.parameters[p].name);
                quote!(p.#name)
            }
            (Leaf::Time, Place::Copy) => quote!(t),
            (Leaf::Time, Place::Push) => quote!(at),
            (Leaf::State(k), Place::Copy) => {
                let k = count(k.index());
                quote!(x[#k])
            }
            (Leaf::Input(j), Place::Copy) => {
                let j = count(j.index());
                quote!(u[#j])
            }
            // Residuals read neither time nor the copy's own leaves.
            _ => {
                self.refuse("time or a state of the copy read outside the copy")
                    .0
            }
        }
    }

    /// Records why the code cannot be written; what stands in its place is never printed.
    fn refuse(&self, why: &'static str) -> (TokenStream, u8) {
        self.refused
            .set(self.refused.get().or(Some(Unwritable(why))));
        (quote!(unwritable), ATOM)
    }

    /// `let`s for every node of `roots` used more than once and for each named node they
    /// read (named `name`, the others `prefix1`, `prefix2`…), bound from here on.
    fn bind_shared(
        &mut self,
        roots: &[Code],
        named: &[(Code, String)],
        prefix: &str,
    ) -> Vec<TokenStream> {
        let mut lets = Vec::new();
        for (id, binding) in bindings(&self.program.code, roots, named) {
            let (value, _) = self.expr(id);
            let name = match binding {
                Binding::Named(name) => format_ident!("{}", name),
                Binding::Numbered(k) => format_ident!("{}{}", prefix, k),
            };
            lets.push(quote!(let #name = #value;));
            self.bound.insert(id, name);
        }
        lets
    }
}

/// A count as a Rust literal, without a suffix.
fn count(n: usize) -> Literal {
    Literal::usize_unsuffixed(n)
}

/// A number as a Rust literal (negative ones as a negation; infinities by name). A NaN
/// cannot be computed with: the code is refused.
fn number(x: f64, refused: &Cell<Option<Unwritable>>) -> (TokenStream, u8) {
    if x.is_nan() {
        refused.set(refused.get().or(Some(Unwritable(
            "a constant that is not a number (a division of zero by zero, or a law outside its domain, in the model's numbers)",
        ))));
        return (quote!(unwritable), ATOM);
    }
    if x.is_infinite() {
        return if x > 0.0 {
            (quote!(f64::INFINITY), ATOM)
        } else {
            (quote!(f64::NEG_INFINITY), ATOM)
        };
    }
    let lit = Literal::f64_unsuffixed(x.abs());
    if x.is_sign_negative() && x != 0.0 {
        (quote!(-#lit), UNARY)
    } else {
        (quote!(#lit), ATOM)
    }
}

/// The body of `residuals`: `let`s for shared nodes and auxiliary signals, then the array.
fn residual_body(lower: &mut Lowering<'_>) -> TokenStream {
    let roots: Vec<Code> = lower.program.residuals.iter().map(|r| r.code).collect();
    let lets = lower.bind_shared(&roots, &lower.program.named, "t");
    let values: Vec<TokenStream> = roots.iter().map(|&r| lower.expr(r).0).collect();
    quote! {
        #(#lets)*
        [#(#values),*]
    }
}

/// Each residual's bound from parameter uncertainty, `Σ |∂r/∂θ| u.θ`, with the nodes its
/// sensitivities share computed once.
fn bounds_body(lower: &mut Lowering<'_>) -> TokenStream {
    let program = lower.program;
    let roots: Vec<Code> = program.sensitivities.iter().map(|s| s.code).collect();
    let lets = lower.bind_shared(&roots, &[], "b");
    let sums: Vec<TokenStream> = (0..program.residuals.len())
        .map(|k| {
            let terms: Vec<TokenStream> = (program.sensitivities.iter())
                .filter(|s| s.residual == k)
                .map(|s| {
                    let (value, _) = lower.expr(s.code);
                    let name = ident(&lower.c.parameters[s.parameter].name);
                    quote!(f64::abs(#value) * u.#name)
                })
                .collect();
            if terms.is_empty() {
                quote!(0.0)
            } else {
                quote!(#(#terms)+*)
            }
        })
        .collect();
    quote! {
        #(#lets)*
        [#(#sums),*]
    }
}

/// The items `COPY_STATES`, `COPY_STATE_NAMES`, `COPY_INPUTS` and `copy_rates` of the copy
/// of the model simulated residuals run; `None` when no residual runs one.
fn copy_items(lower: &mut Lowering<'_>) -> Option<TokenStream> {
    let program = lower.program;
    let copy = program.copy.as_ref()?;
    let lets = lower.bind_shared(&copy.rates, &[], "t");
    let rates: Vec<TokenStream> = copy.rates.iter().map(|&r| lower.expr(r).0).collect();
    let slots: Vec<Literal> = (0..rates.len()).map(count).collect();
    let m = count(rates.len());
    let names = &copy.names;
    let input_names: Vec<&str> = (copy.inputs.iter())
        .map(|&h| program.raw[h].name.as_str())
        .collect();
    let k = count(copy.inputs.len());
    Some(quote! {
        /// How many states the copy of the model that simulated residuals run has: the
        /// model's, then one per `int(..)` its state equations hold; all zero at the start
        /// (the model at rest).
        pub const COPY_STATES: usize = #m;

        /// The copy's states, in the order of [`copy_rates`]' `x`.
        pub const COPY_STATE_NAMES: [&str; COPY_STATES] = [#(#names),*];

        /// The inputs the copy reads, in the order of [`copy_rates`]' `u`.
        pub const COPY_INPUTS: [&str; #k] = [#(#input_names),*];

        /// The copy's rates at time `t`, states `x` and inputs `u`, written into `dx`: the
        /// model's state equations, then the argument of each `int(..)` they hold.
        #[allow(non_snake_case, unused_variables, clippy::all)]
        pub fn copy_rates(p: &Params, t: f64, x: &[f64], u: &[f64], dx: &mut [f64]) {
            #(#lets)*
            #(dx[#slots] = #rates;)*
        }
    })
}

/// The model's residual code as tokens: `Params`, `Signals`, `residuals`, the FSM and the
/// streaming `ResidualGenerator`, printed from the model's residual program. Every item may
/// go unused: the code is included in a user's module (`mod m { include!(...) }`), where a
/// bench program reads a part of it, and must not warn there, nor be linted by the user's
/// clippy as if written by hand.
pub fn tokens(c: &Compiled) -> Result<TokenStream, Unwritable> {
    let refused = Cell::new(None);
    let items = items(c, &refused);
    if let Some(why) = refused.get() {
        return Err(why);
    }
    let Ok(mut file) = syn::parse2::<syn::File>(items.clone()) else {
        return Ok(items);
    };
    let allow: syn::Attribute =
        syn::parse_quote!(#[allow(dead_code, unreachable_pub, clippy::all)]);
    for item in &mut file.items {
        let attrs = match item {
            syn::Item::Const(i) => &mut i.attrs,
            syn::Item::Struct(i) => &mut i.attrs,
            syn::Item::Fn(i) => &mut i.attrs,
            syn::Item::Impl(i) => &mut i.attrs,
            syn::Item::Static(i) => &mut i.attrs,
            syn::Item::Type(i) => &mut i.attrs,
            syn::Item::Enum(i) => &mut i.attrs,
            _ => continue,
        };
        attrs.push(allow.clone());
    }
    Ok(quote!(#file))
}

/// The items of [`tokens`], before each is allowed to go unused.
fn items(c: &Compiled, refused: &Cell<Option<Unwritable>>) -> TokenStream {
    let program = c.program();
    let readings = c.readings();
    let fields = fields(c, &program, &readings);
    let params = params(c, refused);
    let signals = signals(&fields);
    let n = count(program.residuals.len());
    let body = residual_body(&mut Lowering::new(
        c,
        &program,
        &fields,
        refused,
        Place::Residuals,
    ));
    let bounds = bounds_body(&mut Lowering::new(
        c,
        &program,
        &fields,
        refused,
        Place::Residuals,
    ));
    let printer = Printer::new(&c.exprs, |s| names::latex(c, s));
    let docs: Vec<String> = c
        .arrs
        .iter()
        .map(|a| {
            let simulated = match a.form {
                ResidualForm::Relation => "",
                ResidualForm::Simulated => {
                    " (simulated: the states of the copy of the model, see [`copy_rates`])"
                }
            };
            let relation = format!(
                " - {}: $${} = 0$${simulated}",
                a.name,
                printer.latex(a.expr)
            );
            match &a.realisation {
                Realisation::Direct => relation,
                Realisation::Integrated(i) => format!(
                    "{relation}; integrated: the running value is $${}$$",
                    printer.latex(i.expr)
                ),
            }
        })
        .collect();
    let integrated: Vec<bool> = (program.residuals.iter())
        .map(|r| r.evaluation == Evaluation::Integrated)
        .collect();
    let arr_names: Vec<&str> = program.residuals.iter().map(|r| r.name.as_str()).collect();
    let simulated: Vec<bool> = (c.arrs.iter())
        .map(|a| a.form == ResidualForm::Simulated)
        .collect();
    let fsm = fsm(c);
    let copy = copy_items(&mut Lowering::new(
        c,
        &program,
        &fields,
        refused,
        Place::Copy,
    ));
    let generator = generator(
        &program,
        &fields,
        &Lowering::new(c, &program, &fields, refused, Place::Push),
    );
    // `f64`'s own `exp`, `sqrt`… come first where `std` is; in a crate without it (a
    // firmware), these are the runtime's.
    quote! {
        #[allow(unused_imports)]
        use ::bondgraph::Real as _;

        #params
        #signals
        #copy

        /// How many residuals [`residuals`] returns: one per ARR.
        pub const RESIDUAL_COUNT: usize = #n;

        /// The ARRs' names, in the order of [`residuals`].
        pub const RESIDUALS: [&str; #n] = [#(#arr_names),*];

        /// Whether each residual is simulated: it compares a measured signal with a copy of
        /// the model run on the recorded inputs from rest, so it holds on a record that
        /// starts with the machine at rest.
        pub const SIMULATED: [bool; #n] = [#(#simulated),*];

        /// Whether each residual is realised by integration: the ARR `r = A + dF/dt` is
        /// evaluated as the running value `F + ∫A` (what [`residuals`] returns for it), whose
        /// change since a reference instant ([`bondgraph::Reference`]) is the residual
        /// `∫ r dt`: it reads each derivative one order lower than the relation.
        pub const INTEGRATED: [bool; #n] = [#(#integrated),*];

        /// Every ARR's residual, in the order of [`RESIDUALS`]; each is zero (up to the
        /// estimation of the signals) while the machine is healthy. For a residual realised
        /// by integration ([`INTEGRATED`]) it is the running value `F + ∫A`, whose change
        /// since a reference instant is zero while the machine is healthy.
        ///
        #(#[doc = #docs])*
        #[allow(non_snake_case, unused_variables, clippy::all)]
        #[must_use]
        pub fn residuals(p: &Params, s: &Signals) -> [f64; #n] {
            #body
        }

        /// Each residual's bound from the uncertainty of the model's parameters at the signals
        /// `s`: `Σ |∂r/∂θ| Δθ` over the uncertain parameters each ARR depends on, `Δθ` read
        /// from `u` (usually [`Params::UNCERTAINTY`]). An adaptive threshold is this plus a
        /// margin for noise; a healthy plant whose parameters are within `u` of `p` stays
        /// under it to first order. An ARR that reads auxiliary signals, or one realised by
        /// integration ([`INTEGRATED`]), has no bound (0): generate the code with
        /// `realise = direct` (`--realise direct`) for adaptive thresholds.
        #[allow(non_snake_case, unused_variables, clippy::all)]
        #[must_use]
        pub fn bounds(p: &Params, u: &Params, s: &Signals) -> [f64; #n] {
            #bounds
        }

        #fsm
        #generator
    }
}

fn params(c: &Compiled, refused: &Cell<Option<Unwritable>>) -> TokenStream {
    let names: Vec<Ident> = c.parameters.values().map(|p| ident(&p.name)).collect();
    let docs: Vec<String> = c
        .parameters
        .values()
        .map(|p| {
            let mut doc = format!(" `{}`", p.name);
            if let Some(u) = &p.unit {
                doc += &format!(" [{u}]");
            }
            if let Some(d) = &p.description {
                doc += &format!(": {d}");
            }
            doc + &format!(" (model value {})", p.value)
        })
        .collect();
    let values: Vec<TokenStream> = (c.parameters.values())
        .map(|p| number(p.value, refused).0)
        .collect();
    let uncertainties: Vec<TokenStream> = c
        .parameters
        .values()
        .map(|p| number(p.uncertainty.unwrap_or(0.0), refused).0)
        .collect();
    let strings: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    let by_place = by_place("Params", &strings);
    quote! {
        /// The model's parameters; [`Default`] gives the values the model declares.
        #[allow(non_snake_case)]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Params {
            #(#[doc = #docs] pub #names: f64,)*
        }

        impl Default for Params {
            fn default() -> Self {
                Params { #(#names: #values,)* }
            }
        }

        impl Params {
            /// How far each parameter's true value may be from the model's (`+- 5%` in the
            /// model), as a half-width in its unit; 0 for those it states exactly.
            pub const UNCERTAINTY: Params = Params { #(#names: #uncertainties,)* };

            #by_place
        }
    }
}

/// The items of a struct of `f64` fields named `fields` that read and write it by place:
/// `NAMES`, `from_array` and `to_array`.
fn by_place(ty: &str, fields: &[&str]) -> TokenStream {
    let names: Vec<Ident> = fields.iter().map(|f| ident(f)).collect();
    let k = count(fields.len());
    let ty_ident = Ident::new(ty, proc_macro2::Span::call_site());
    let from = format!(" The fields from an array in the order of [`{ty}::NAMES`].");
    let to = format!(" The fields as an array in the order of [`{ty}::NAMES`].");
    quote! {
        /// The fields' names, in order.
        pub const NAMES: [&'static str; #k] = [#(#fields),*];

        #[doc = #from]
        #[must_use]
        #[allow(non_snake_case)]
        pub fn from_array(a: [f64; #k]) -> Self {
            let [#(#names),*] = a;
            #ty_ident { #(#names),* }
        }

        #[doc = #to]
        #[must_use]
        pub fn to_array(&self) -> [f64; #k] {
            [#(self.#names),*]
        }
    }
}

fn signals(fields: &[Field]) -> TokenStream {
    let names: Vec<Ident> = fields.iter().map(|f| ident(&f.name)).collect();
    let strings: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
    let docs: Vec<String> = fields.iter().map(|f| format!(" {}", f.doc)).collect();
    let by_place = by_place("Signals", &strings);
    quote! {
        /// What the residuals read: the inputs and measured signals, their time derivatives
        /// (`NAME_d1`, `NAME_d2`…) and integrals from the start of the record (`NAME_int`).
        #[allow(non_snake_case)]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct Signals {
            #(#[doc = #docs] pub #names: f64,)*
        }

        impl Signals {
            #by_place
        }
    }
}

fn fsm(c: &Compiled) -> TokenStream {
    let n = count(c.arrs.len());
    let rows: Vec<TokenStream> = c
        .components
        .values()
        .map(|comp| {
            let name = &comp.name;
            let kind = comp.kind.name();
            // Sparse: a dense row per component grows with the square of the model.
            let marks = comp.marks.iter().map(|&k| count(k));
            let (db, ib) = (comp.detectable, comp.isolable);
            quote! {
                ::bondgraph::Component {
                    name: #name,
                    kind: #kind,
                    signature: ::bondgraph::Signature::new(#n, &[#(#marks),*]),
                    detectable: #db,
                    isolable: #ib,
                }
            }
        })
        .collect();
    quote! {
        /// The fault signature matrix: which residuals a fault of each component moves.
        pub const FSM: ::bondgraph::Fsm = ::bondgraph::Fsm {
            residuals: &RESIDUALS,
            components: &[#(#rows),*],
        };

        /// The components whose fault explains the residuals in alarm (see
        /// [`bondgraph::Fsm::candidates`]).
        #[must_use]
        pub fn candidates(alarms: &[bool; #n]) -> ::bondgraph::Vec<&'static str> {
            FSM.candidates(alarms)
        }

        /// The components whose fault is consistent with the residuals in alarm, with no
        /// exoneration (see [`bondgraph::Fsm::suspects`]).
        #[must_use]
        pub fn suspects(alarms: &[bool; #n]) -> ::bondgraph::Vec<&'static str> {
            FSM.suspects(alarms)
        }
    }
}

/// The streaming generator: raw samples in, residuals out, as the program says.
fn generator(program: &Program, fields: &[Field], lower: &Lowering<'_>) -> TokenStream {
    let raw_names: Vec<&str> = program.raw.values().map(|r| r.name.as_str()).collect();
    let order_literals: Vec<Literal> = (program.raw.values())
        .map(|r| Literal::u32_unsuffixed(r.order))
        .collect();
    let r = count(program.raw.len());
    let top = program.top_order();
    let top_literal = Literal::u32_unsuffixed(top);
    // Modulating functions one smoother than the highest order read (see the runtime).
    let smoothness = Literal::u32_unsuffixed(top + 1);
    let channels = count(program.channels.len());
    let differentiated_literal = count(program.differentiated);
    // The bank's estimates by order, bound by a slice pattern that cannot panic.
    let by_order: Vec<Ident> = (0..=top).map(|k| format_ident!("e{}", k)).collect();
    // What each channel is fed: a raw sample, or the next value of a raw signal's integral.
    let mut integrals = 0usize;
    let feeds: Vec<TokenStream> = (program.channels.iter())
        .map(|(h, channel)| {
            let x = count(h.index());
            match channel.source {
                Source::Raw(k) => {
                    let k = count(k.index());
                    quote!(x[#x] = raw[#k];)
                }
                Source::Integral(k) => {
                    let (k, i) = (count(k.index()), count(integrals));
                    integrals += 1;
                    quote!(x[#x] = self.integrals[#i].push(t, raw[#k]);)
                }
            }
        })
        .collect();
    let i = count(integrals);
    // How each field is filled, in the program's order: from the estimates (`e{order}[channel]`),
    // from the copy, or by integrating an expression of the fields before it.
    let mut others = 0usize;
    let mut roots = 0usize;
    let fill: Vec<TokenStream> = fields
        .iter()
        .map(|f| {
            let name = ident(&f.name);
            match program.slots[f.slot].fill {
                Fill::Estimate { channel, order } => {
                    let channel = count(channel.index());
                    let order = format_ident!("e{}", order);
                    quote!(s.#name = #order[#channel];)
                }
                Fill::Simulated(k) => {
                    let k = count(k.index());
                    quote!(s.#name = xh[#k];)
                }
                Fill::Integral(integrand) => {
                    let k = count(others);
                    others += 1;
                    // Each fill's repeated parts are computed once, in a block of its own.
                    let mut lower = lower.fresh();
                    let lets = lower.bind_shared(&[integrand], &[], "e");
                    let (integrand, _) = lower.expr(integrand);
                    if lets.is_empty() {
                        quote!(s.#name = self.others[#k].push(at, #integrand);)
                    } else {
                        quote!(s.#name = {
                            #(#lets)*
                            self.others[#k].push(at, #integrand)
                        };)
                    }
                }
                Fill::Root { residual, slope } => {
                    let k = count(roots);
                    roots += 1;
                    let mut lower = lower.fresh();
                    let lets = lower.bind_shared(&[residual, slope], &[], "e");
                    let (residual, _) = lower.expr(residual);
                    let (slope, _) = lower.expr(slope);
                    let label = &f.name;
                    quote! {
                        s.#name = match self.roots[#k].solve(|z| {
                            s.#name = z;
                            #(#lets)*
                            (#residual, #slope)
                        }) {
                            Some(z) => z,
                            None => {
                                self.unsolved = self.unsolved.or(Some(#label));
                                ::bondgraph::RootFinder::NO_ROOT
                            }
                        };
                    }
                }
            }
        })
        .collect();
    let o = count(others);
    // Any bank estimates values: only derivatives need checking (`order < 0` would warn).
    let order_check = if top == 0 {
        quote!()
    } else {
        quote! {
            if bank.order() < #top_literal {
                return Err(::bondgraph::EstimatorError::Order {
                    order: bank.order(),
                    needed: #top_literal,
                });
            }
        }
    };
    // Only a program that solves roots carries their finders and says which failed.
    let root_count = count(roots);
    let (roots_field, roots_init, roots_reset, roots_method) = if roots == 0 {
        Default::default()
    } else {
        (
            quote! {
                roots: [::bondgraph::RootFinder; #root_count],
                unsolved: Option<&'static str>,
            },
            quote! {
                roots: [::bondgraph::RootFinder::new(); #root_count],
                unsolved: None,
            },
            quote!(self.unsolved = None;),
            quote! {
                /// The root (a field of [`Signals`]) that had no solution at the last
                /// estimate, if any: the residuals that read it are not numbers there, and
                /// say nothing.
                #[must_use]
                pub fn unsolved(&self) -> Option<&'static str> {
                    self.unsolved
                }
            },
        )
    };
    let channel_orders: Vec<Literal> = (program.channels.values())
        .map(|c| Literal::u32_unsuffixed(c.order))
        .collect();
    // The residuals realised by integration, each with its reference.
    let integrated: Vec<Literal> = (program.residuals.iter().enumerate())
        .filter(|(_, r)| r.evaluation == Evaluation::Integrated)
        .map(|(k, _)| count(k))
        .collect();
    let references = count(integrated.len());
    let reference_index: Vec<Literal> = (0..integrated.len()).map(count).collect();
    let (copy_field, copy_init, copy_push, copy_read) = match &program.copy {
        None => Default::default(),
        Some(copy) => {
            let inputs: Vec<Literal> = copy.inputs.iter().map(|h| count(h.index())).collect();
            (
                quote!(copy: ::bondgraph::Replay,),
                quote!(copy: ::bondgraph::Replay::new(&[0.0; COPY_STATES]),),
                quote! {
                    let params = self.params;
                    self.copy.push(t, &[#(raw[#inputs]),*], |t, x, u, dx| {
                        copy_rates(&params, t, x, u, dx)
                    });
                },
                quote!(let xh = self.copy.at(at)?;),
            )
        }
    };
    quote! {
        /// The raw signals [`ResidualGenerator::push`] takes, in order: the inputs and
        /// measured signals the ARRs read.
        pub const RAW_SIGNALS: [&str; #r] = [#(#raw_names),*];

        /// The highest derivative of each raw signal the ARRs read.
        pub const RAW_ORDERS: [u32; #r] = [#(#order_literals),*];

        /// How many signals the generator's estimator bank takes: the raw signals whose
        /// derivatives the ARRs read, the other raw signals, then the trapezoidal integrals of
        /// those whose integral the ARRs read.
        pub const CHANNELS: usize = #channels;

        /// How many of the bank's first [`CHANNELS`] need derivatives.
        pub const DIFFERENTIATED: usize = #differentiated_literal;

        /// The highest derivative the ARRs read of each of the bank's [`CHANNELS`] signals.
        pub const CHANNEL_ORDERS: [u32; CHANNELS] = [#(#channel_orders),*];

        /// Residuals from raw samples. The raw signals and the trapezoidal integrals the ARRs
        /// read go through one estimator bank (`B`), so that every term of an ARR is
        /// filtered alike and refers to the same instant, [`ResidualGenerator::delay`]
        /// seconds before the newest sample.
        #[derive(Clone, Debug)]
        pub struct ResidualGenerator<B = ::bondgraph::SavitzkyGolayBank<CHANNELS, DIFFERENTIATED>> {
            params: Params,
            bank: B,
            integrals: [::bondgraph::Trapezoid; #i],
            others: [::bondgraph::Trapezoid; #o],
            #roots_field
            references: [::bondgraph::Reference; #references],
            #copy_field
            last: Signals,
        }

        impl<B: ::bondgraph::Bank<CHANNELS>> ResidualGenerator<B> {
            /// A generator over `bank`, which must estimate derivatives up to the highest
            /// order of [`CHANNEL_ORDERS`].
            pub fn with_bank(params: Params, bank: B) -> Result<Self, ::bondgraph::EstimatorError> {
                #order_check
                Ok(ResidualGenerator {
                    params,
                    bank,
                    integrals: [::bondgraph::Trapezoid::new(); #i],
                    others: [::bondgraph::Trapezoid::new(); #o],
                    #roots_init
                    references: ::core::array::from_fn(|_| ::bondgraph::Reference::default()),
                    #copy_init
                    last: Signals::default(),
                })
            }

            /// Residuals realised by integration ([`INTEGRATED`]) taken over the last
            /// `samples` steps (by default [`bondgraph::Reference::DEFAULT_WINDOW`]).
            #[must_use]
            pub fn with_integration_window(mut self, samples: usize) -> Self {
                self.references = ::core::array::from_fn(|_| ::bondgraph::Reference::window(samples));
                self
            }

            /// Residuals realised by integration ([`INTEGRATED`]) taken from the first
            /// estimate: a fault that shows only while a signal moves leaves them offset for
            /// good, and the noise they integrate grows with the record (see
            /// [`bondgraph::Reference`]).
            #[must_use]
            pub fn integrated_from_start(mut self) -> Self {
                self.references = ::core::array::from_fn(|_| ::bondgraph::Reference::from_start());
                self
            }

            /// The parameters the residuals are computed with.
            #[must_use]
            pub fn params(&self) -> &Params {
                &self.params
            }

            /// How far the residuals lag the newest sample, in seconds.
            #[must_use]
            pub fn delay(&self) -> f64 {
                self.bank.delay()
            }

            #roots_method

            /// The estimates the last residuals were computed from.
            #[must_use]
            pub fn signals(&self) -> &Signals {
                &self.last
            }

            /// The last residuals' bounds from the parameters' stated uncertainty
            /// ([`bounds`] with [`Params::UNCERTAINTY`]): add a margin for noise to get
            /// adaptive thresholds.
            #[must_use]
            pub fn bounds(&self) -> [f64; RESIDUAL_COUNT] {
                bounds(&self.params, &Params::UNCERTAINTY, &self.last)
            }

            /// Takes the samples of [`RAW_SIGNALS`] at time `t` (uniform steps) and returns
            /// the residuals at `t - self.delay()`, once the bank's windows are full.
            #[allow(unused_mut, unused_variables, clippy::all)]
            pub fn push(&mut self, t: f64, raw: [f64; #r]) -> Option<[f64; RESIDUAL_COUNT]> {
                #copy_push
                let mut x = [0.0; CHANNELS];
                #(#feeds)*
                let at = t - self.bank.delay();
                let [#(#by_order,)* ..] = self.bank.push(x)? else {
                    return None;
                };
                #copy_read
                let p = &self.params;
                #roots_reset
                let mut s = Signals::default();
                #(#fill)*
                let mut r = residuals(p, &s);
                #(r[#integrated] = self.references[#reference_index].push(r[#integrated]);)*
                self.last = s;
                Some(r)
            }
        }

        /// What [`bondgraph::FaultSize`] runs, at the parameter values it linearises
        /// around, to size a fault once a class alarms.
        impl<B: ::bondgraph::Bank<CHANNELS> + Clone> ::bondgraph::Parametrised for ResidualGenerator<B> {
            fn parameter_count(&self) -> usize {
                Params::NAMES.len()
            }

            fn parameter(&self, k: usize) -> f64 {
                self.params.to_array()[k]
            }

            fn set_parameter(&mut self, k: usize, value: f64) {
                let mut a = self.params.to_array();
                a[k] = value;
                self.params = Params::from_array(a);
            }

            fn residual_count(&self) -> usize {
                RESIDUAL_COUNT
            }

            fn push_raw(&mut self, t: f64, raw: &[f64], residuals: &mut [f64]) -> bool {
                let Ok(raw) = <[f64; #r]>::try_from(raw) else {
                    return false;
                };
                match self.push(t, raw) {
                    Some(r) => {
                        residuals[..RESIDUAL_COUNT].copy_from_slice(&r);
                        true
                    }
                    None => false,
                }
            }
        }

        impl ResidualGenerator<::bondgraph::SavitzkyGolayBank<CHANNELS, DIFFERENTIATED>> {
            /// A generator with centred Savitzky–Golay fits of `degree` over `window` samples
            /// (odd) taken every `step` seconds: delay `(window − 1)/2` samples.
            pub fn savitzky_golay(
                params: Params,
                step: f64,
                window: usize,
                degree: u32,
            ) -> Result<Self, ::bondgraph::EstimatorError> {
                let bank = ::bondgraph::SavitzkyGolayBank::new(#top_literal, degree, window, step, true)?;
                Self::with_bank(params, bank)
            }
        }

        impl ResidualGenerator<::bondgraph::Each<::bondgraph::ModulatingFunction, CHANNELS>> {
            /// A generator with the same modulating function on every signal, over `window`
            /// samples (odd) taken every `step` seconds, of smoothness one above the highest
            /// derivative read: no signal is differentiated, and an ARR linear in the signals
            /// holds on the estimates at any window (see [`bondgraph::ModulatingFunction`]).
            pub fn modulating(params: Params, step: f64, window: usize) -> Result<Self, ::bondgraph::EstimatorError> {
                let bank = ::bondgraph::Each::new(CHANNEL_ORDERS, |order| {
                    ::bondgraph::ModulatingFunction::new(order, #smoothness, window, step)
                })?;
                Self::with_bank(params, bank)
            }
        }

        impl<D: ::bondgraph::Differentiator> ResidualGenerator<::bondgraph::Each<D, CHANNELS>> {
            /// A generator with the estimator `estimator(order)` for each of the bank's
            /// signals (`order` from [`CHANNEL_ORDERS`]): a
            /// [`StateVariableFilter`](::bondgraph::StateVariableFilter) per signal, say.
            /// Every estimator should have the same delay.
            pub fn with_estimators(
                params: Params,
                estimator: impl FnMut(u32) -> Result<D, ::bondgraph::EstimatorError>,
            ) -> Result<Self, ::bondgraph::EstimatorError> {
                let bank = ::bondgraph::Each::new(CHANNEL_ORDERS, estimator)?;
                Self::with_bank(params, bank)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Model names become Rust identifiers that compile: keywords raw, the few that cannot be
    /// raw with a trailing underscore.
    #[test]
    fn model_names_become_identifiers() {
        assert_eq!(ident("Re").to_string(), "Re");
        assert_eq!(ident("type").to_string(), "r#type");
        assert_eq!(ident("self").to_string(), "self_");
        assert_eq!(ident("_").to_string(), "__");
        for k in KEYWORDS {
            assert!(
                syn::parse_str::<syn::Ident>(&ident(k).to_string()).is_ok(),
                "{k}"
            );
        }
    }

    /// A number the code cannot compute with refuses the code instead of printing a NaN;
    /// an infinity is written by name (it used to be written as a NaN too).
    #[test]
    fn numbers_are_written_or_refused() {
        let refused = Cell::new(None);
        assert_eq!(number(2.5, &refused).0.to_string(), "2.5");
        assert_eq!(number(-2.0, &refused).0.to_string(), "- 2.0");
        assert_eq!(
            number(f64::INFINITY, &refused).0.to_string(),
            quote!(f64::INFINITY).to_string()
        );
        assert_eq!(
            number(f64::NEG_INFINITY, &refused).0.to_string(),
            quote!(f64::NEG_INFINITY).to_string()
        );
        assert!(refused.get().is_none());
        number(f64::NAN, &refused);
        let why = refused.get().expect("refused");
        assert!(why.to_string().contains("not a number"), "{why}");
    }

    /// No model's code holds a NaN: every model of `models/` is written.
    #[test]
    fn every_model_is_written_without_a_nan() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut paths: Vec<_> = std::fs::read_dir(dir)
            .expect("models/")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "bg"))
            .collect();
        paths.sort();
        for path in paths {
            let text = std::fs::read_to_string(&path).expect("model");
            let out = bondgraph_core::compile(&text, "m.bg", &bondgraph_core::Options::default())
                .expect("valid");
            let code = emit(&out.compiled).expect("written");
            assert!(!code.contains("NAN"), "{}", path.display());
        }
    }
}
