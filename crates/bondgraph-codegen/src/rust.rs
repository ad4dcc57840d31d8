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

use std::collections::{BTreeMap, HashMap};

use bondgraph_core::{
    children, Arr, Auxiliary, BinOp, Compiled, Expr, Func, Handle, Input, Node, Printer, Quantity,
    Readings, Realisation, ResidualForm, Signal, Symbol,
};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

use crate::names;

/// The model's items, formatted, with a header naming the model.
pub fn emit(c: &Compiled) -> String {
    let file = match syn::parse2::<syn::File>(tokens(c)) {
        Ok(file) => prettyplease::unparse(&file),
        // The generator writes only what parses; if not, the tokens as they are.
        Err(_) => tokens(c).to_string(),
    };
    format!(
        "// Residual code for the model `{}` ({}), written by bgc.\n// It needs the `bondgraph` runtime crate.\n\n{file}",
        c.name, c.file_name
    )
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

/// One field of `Signals`.
struct Field {
    name: String,
    quantity: Quantity,
    doc: String,
}

/// The fields of `Signals`, in the order of the product's readings: per signal its value,
/// derivatives and integral, then the integrals of nonlinear expressions.
fn fields(c: &Compiled, readings: &Readings) -> Vec<Field> {
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let name_of = |signal: Signal| match signal {
        Signal::Input(u) => (&c.inputs[u].name, "input"),
        Signal::Sensor(s) => (&c.sensors[s].name, "measured signal"),
    };
    readings
        .quantities
        .iter()
        .map(|&quantity| {
            let (name, doc) = match quantity {
                Quantity::Derivative(signal, 0) => {
                    let (name, what) = name_of(signal);
                    (name.clone(), format!("The {what} `{name}`."))
                }
                Quantity::Derivative(signal, n) => {
                    let (name, _) = name_of(signal);
                    (
                        format!("{name}_d{n}"),
                        format!("The time derivative of order {n} of `{name}`."),
                    )
                }
                Quantity::Integral(signal) => {
                    let (name, _) = name_of(signal);
                    (
                        format!("{name}_int"),
                        format!("The integral of `{name}` from the start of the record."),
                    )
                }
                Quantity::Nonlinear(k) => (
                    format!("int{}", k + 1),
                    format!(
                        "`int({})`: the integral from the start of the record of an expression that is not linear in the signals.",
                        printer.text(readings.nonlinear[k])
                    ),
                ),
                Quantity::Simulated(k) => {
                    let name = &c.states[k].name;
                    (
                        format!("{name}_hat"),
                        format!("The state `{name}` of the copy of the model that simulated residuals run."),
                    )
                }
            };
            Field {
                name,
                quantity,
                doc,
            }
        })
        .collect()
}

/// Binding strengths of Rust expressions as the lowering writes them.
const SUM: u8 = 1;
const PRODUCT: u8 = 2;
const UNARY: u8 = 3;
const ATOM: u8 = 5;

/// How the right-hand sides of the copy of the model read its states and inputs:
/// `x[k]`, `u[j]`, and each `int(..)` as the state after the model's.
#[derive(Clone)]
struct CopyLeaves {
    states: usize,
    integrals: Vec<Expr>,
    inputs: Vec<Handle<Input>>,
}

/// Lowers product expressions to Rust, with shared nodes bound once.
struct Lowering<'c> {
    c: &'c Compiled,
    /// Lowering the copy's rates instead of residuals.
    copy: Option<CopyLeaves>,
    /// Each signal quantity's field.
    field: HashMap<Quantity, Ident>,
    /// Nodes already bound to a `let`.
    bound: HashMap<Expr, Ident>,
    /// Each auxiliary signal's derivative, once bound.
    auxiliary: HashMap<(Handle<Auxiliary>, u32), Ident>,
    others: Vec<Expr>,
}

impl Lowering<'_> {
    fn wrap(ts: TokenStream, prec: u8, needed: u8) -> TokenStream {
        if prec < needed {
            quote!((#ts))
        } else {
            ts
        }
    }

    /// `e` as Rust, with its binding strength.
    fn expr(&self, e: Expr) -> (TokenStream, u8) {
        if let Some(name) = self.bound.get(&e) {
            return (quote!(#name), ATOM);
        }
        match self.c.exprs.node(e) {
            Node::Num(bits) => number(f64::from_bits(bits)),
            Node::Leaf(s) => (self.leaf(s), ATOM),
            Node::Neg(a) => {
                let a = self.operand(a, UNARY);
                (quote!(-#a), UNARY)
            }
            Node::Binary(BinOp::Pow, a, b) => {
                let base = self.receiver(a);
                match self.c.exprs.node(b) {
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
            Node::Int(a) if self.copy.is_some() => {
                let copy = self.copy.as_ref().map_or((0, None), |c| {
                    (c.states, c.integrals.iter().position(|&e| e == a))
                });
                let k = count(copy.0 + copy.1.unwrap_or(0));
                (quote!(x[#k]), ATOM)
            }
            Node::Int(a) => {
                let single = self
                    .c
                    .linear_terms(a)
                    .is_some_and(|t| t.len() == 1 && t[0].0 && t[0].1.is_none());
                (self.integral(a), if single { ATOM } else { SUM })
            }
        }
    }

    fn operand(&self, e: Expr, needed: u8) -> TokenStream {
        let (ts, prec) = self.expr(e);
        Self::wrap(ts, prec, needed)
    }

    /// `e` as the receiver of a method call: a number needs its type (`2.0_f64.exp()`).
    fn receiver(&self, e: Expr) -> TokenStream {
        match self.c.exprs.node(e) {
            Node::Num(bits) if !self.bound.contains_key(&e) => {
                let lit = Literal::f64_suffixed(f64::from_bits(bits));
                quote!((#lit))
            }
            _ => self.operand(e, ATOM),
        }
    }

    fn leaf(&self, s: Symbol) -> TokenStream {
        let field = |q: Quantity| match self.field.get(&q) {
            Some(name) => quote!(s.#name),
            // Every quantity an ARR reads has a field (see `fields`).
            None => quote!(f64::NAN),
        };
        if let Some(copy) = &self.copy {
            match s {
                Symbol::State(k) => {
                    let k = count(k.index());
                    return quote!(x[#k]);
                }
                Symbol::Input(u, 0) => {
                    let j = count(copy.inputs.iter().position(|&i| i == u).unwrap_or(0));
                    return quote!(u[#j]);
                }
                Symbol::Time => return quote!(t),
                _ => {}
            }
        }
        match s {
            Symbol::Parameter(p) => {
                let name = ident(&self.c.parameters[p].name);
                quote!(p.#name)
            }
            Symbol::Input(u, n) => field(Quantity::Derivative(Signal::Input(u), n)),
            Symbol::Sensor(h, n) => field(Quantity::Derivative(Signal::Sensor(h), n)),
            Symbol::Auxiliary(a, n) => match self.auxiliary.get(&(a, n)) {
                Some(name) => quote!(#name),
                None => quote!(f64::NAN),
            },
            // A simulated residual reads the states of the copy of the model.
            Symbol::State(k) => field(Quantity::Simulated(k)),
            // ARRs read neither time nor the loops of the state equations.
            Symbol::Time | Symbol::Loop(_) => quote!(f64::NAN),
        }
    }

    /// `int(a)`: the integrals of the signals it combines linearly, or its own field.
    fn integral(&self, a: Expr) -> TokenStream {
        if let Some(k) = self.others.iter().position(|&e| e == a) {
            let name = &self.field[&Quantity::Nonlinear(k)];
            return quote!(s.#name);
        }
        let mut out: Option<TokenStream> = None;
        for (positive, coefficient, signal) in self.c.linear_terms(a).unwrap_or_default() {
            let Some(name) = self.field.get(&Quantity::Integral(signal)) else {
                continue;
            };
            let term = match coefficient {
                Some(k) => {
                    let k = self.operand(k, PRODUCT);
                    quote!(#k * s.#name)
                }
                None => quote!(s.#name),
            };
            out = Some(match (out, positive) {
                (None, true) => term,
                (None, false) => quote!(-#term),
                (Some(o), true) => quote!(#o + #term),
                (Some(o), false) => quote!(#o - #term),
            });
        }
        out.unwrap_or_else(|| quote!(0.0))
    }
}

/// A count as a Rust literal, without a suffix.
fn count(n: usize) -> Literal {
    Literal::usize_unsuffixed(n)
}

/// A number as a Rust literal (negative ones as a negation).
fn number(x: f64) -> (TokenStream, u8) {
    let lit = Literal::f64_unsuffixed(x.abs());
    if x.is_sign_negative() && x != 0.0 {
        (quote!(-#lit), UNARY)
    } else {
        (quote!(#lit), ATOM)
    }
}

/// How many times each node is reached from `roots` (once per parent edge), children first.
fn uses(c: &Compiled, roots: &[Expr]) -> (Vec<Expr>, HashMap<Expr, usize>) {
    let mut order = Vec::new();
    let mut count: HashMap<Expr, usize> = HashMap::new();
    c.exprs.visit_reachable(roots, |id, node| {
        order.push(id);
        for child in children(node) {
            *count.entry(child).or_default() += 1;
        }
    });
    for &r in roots {
        *count.entry(r).or_default() += 1;
    }
    (order, count)
}

/// The body of `residuals`: `let`s for shared nodes and auxiliary signals, then the array.
fn residual_body(lower: &mut Lowering<'_>, c: &Compiled) -> TokenStream {
    let roots: Vec<Expr> = c.arrs.iter().map(Arr::evaluated).collect();
    let read = c.auxiliary_derivatives_read(&roots);
    let mut all_roots = roots.clone();
    for &(a, n) in &read {
        all_roots.push(c.auxiliaries[a].derivatives[n as usize]);
    }
    let (order, count) = uses(c, &all_roots);
    let aux_root: HashMap<Expr, Vec<(Handle<Auxiliary>, u32)>> =
        read.iter().fold(HashMap::new(), |mut m, &(a, n)| {
            let e = c.auxiliaries[a].derivatives[n as usize];
            m.entry(e).or_default().push((a, n));
            m
        });
    let mut lets = Vec::new();
    let mut next = 0usize;
    for id in order {
        let shared = count.get(&id).copied().unwrap_or(0) >= 2
            && !matches!(c.exprs.node(id), Node::Num(_) | Node::Leaf(_));
        let named = aux_root.get(&id);
        if !shared && named.is_none() {
            continue;
        }
        let (value, _) = lower.expr(id);
        let name = match named.and_then(|v| v.first()) {
            Some(&(a, n)) => {
                let aux = &c.auxiliaries[a];
                match n {
                    0 => format_ident!("{}", aux.name),
                    n => format_ident!("{}_d{}", aux.name, n),
                }
            }
            None => {
                next += 1;
                format_ident!("t{}", next)
            }
        };
        lets.push(quote!(let #name = #value;));
        for &key in named.into_iter().flatten() {
            lower.auxiliary.insert(key, name.clone());
        }
        lower.bound.insert(id, name);
    }
    let values: Vec<TokenStream> = roots.iter().map(|&r| lower.expr(r).0).collect();
    quote! {
        #(#lets)*
        [#(#values),*]
    }
}

/// Each ARR's bound from parameter uncertainty, `Σ |∂r/∂θ| u.θ`, with the nodes its
/// sensitivities share computed once.
fn bounds_body(c: &Compiled, template: &Lowering<'_>) -> TokenStream {
    let mut lower = Lowering {
        c,
        field: template.field.clone(),
        copy: None,
        bound: HashMap::new(),
        auxiliary: HashMap::new(),
        others: template.others.clone(),
    };
    let roots: Vec<Expr> = c
        .arrs
        .iter()
        .flat_map(|a| a.sensitivities.iter().flatten().map(|&(_, e)| e))
        .collect();
    let (order, count) = uses(c, &roots);
    let mut lets = Vec::new();
    for id in order {
        let shared = count.get(&id).copied().unwrap_or(0) >= 2
            && !matches!(c.exprs.node(id), Node::Num(_) | Node::Leaf(_));
        if shared {
            let (value, _) = lower.expr(id);
            let name = format_ident!("b{}", lets.len() + 1);
            lets.push(quote!(let #name = #value;));
            lower.bound.insert(id, name);
        }
    }
    let sums: Vec<TokenStream> = c
        .arrs
        .iter()
        .map(|a| {
            let terms: Vec<TokenStream> = a
                .sensitivities
                .iter()
                .flatten()
                .map(|&(p, e)| {
                    let (value, _) = lower.expr(e);
                    let name = ident(&c.parameters[p].name);
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

/// The copy of the model simulated residuals run: how its rates read states and inputs, and
/// the items `COPY_STATES`, `COPY_INPUTS` and `copy_rates`; `None` when no residual runs one.
fn copy_items(c: &Compiled, readings: &Readings) -> Option<(CopyLeaves, TokenStream)> {
    let copy = readings.copy.as_ref()?;
    let inputs = &copy.inputs;
    let leaves = CopyLeaves {
        states: c.states.len(),
        integrals: copy.integrals.clone(),
        inputs: inputs.clone(),
    };
    let mut lower = Lowering {
        c,
        copy: Some(leaves.clone()),
        field: HashMap::new(),
        bound: HashMap::new(),
        auxiliary: HashMap::new(),
        others: Vec::new(),
    };
    let (order, uses) = uses(c, &copy.rates);
    let mut lets = Vec::new();
    for id in order {
        let shared = uses.get(&id).copied().unwrap_or(0) >= 2
            && !matches!(
                c.exprs.node(id),
                Node::Num(_) | Node::Leaf(_) | Node::Int(_)
            );
        if shared {
            let (value, _) = lower.expr(id);
            let name = format_ident!("t{}", lets.len() + 1);
            lets.push(quote!(let #name = #value;));
            lower.bound.insert(id, name);
        }
    }
    let rates: Vec<TokenStream> = copy.rates.iter().map(|&r| lower.expr(r).0).collect();
    let slots: Vec<Literal> = (0..rates.len()).map(count).collect();
    let m = count(rates.len());
    let names: Vec<String> = (c.states.values().map(|s| s.name.clone()))
        .chain((1..=copy.integrals.len()).map(|k| format!("int{k}")))
        .collect();
    let input_names: Vec<&str> = inputs.iter().map(|&u| c.inputs[u].name.as_str()).collect();
    let k = count(inputs.len());
    let items = quote! {
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
    };
    Some((leaves, items))
}

/// The model's residual code as tokens: `Params`, `Signals`, `residuals`, the FSM and the
/// streaming `ResidualGenerator`.
pub fn tokens(c: &Compiled) -> TokenStream {
    let readings = c.readings();
    let others = readings.nonlinear.clone();
    let fields = fields(c, &readings);
    let mut lower = Lowering {
        c,
        field: fields
            .iter()
            .map(|f| (f.quantity, ident(&f.name)))
            .collect(),
        copy: None,
        bound: HashMap::new(),
        auxiliary: HashMap::new(),
        others: others.clone(),
    };
    let params = params(c);
    let signals = signals(&fields);
    let n = count(c.arrs.len());
    let body = residual_body(&mut lower, c);
    let bounds = bounds_body(c, &lower);
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
    let integrated: Vec<bool> = (c.arrs.iter())
        .map(|a| matches!(a.realisation, Realisation::Integrated(_)))
        .collect();
    let arr_names: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
    let simulated: Vec<bool> = (c.arrs.iter())
        .map(|a| a.form == ResidualForm::Simulated)
        .collect();
    let fsm = fsm(c);
    let copy = copy_items(c, &readings);
    let generator = generator(c, &readings, &fields, &lower, copy.as_ref().map(|x| &x.0));
    let copy = copy.map(|x| x.1);
    quote! {
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

fn params(c: &Compiled) -> TokenStream {
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
    let values: Vec<TokenStream> = c.parameters.values().map(|p| number(p.value).0).collect();
    let uncertainties: Vec<TokenStream> = c
        .parameters
        .values()
        .map(|p| number(p.uncertainty.unwrap_or(0.0)).0)
        .collect();
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
        }
    }
}

fn signals(fields: &[Field]) -> TokenStream {
    let names: Vec<Ident> = fields.iter().map(|f| ident(&f.name)).collect();
    let strings: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
    let docs: Vec<String> = fields.iter().map(|f| format!(" {}", f.doc)).collect();
    let k = count(fields.len());
    quote! {
        /// What the residuals read: the inputs and measured signals, their time derivatives
        /// (`NAME_d1`, `NAME_d2`…) and integrals from the start of the record (`NAME_int`).
        #[allow(non_snake_case)]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct Signals {
            #(#[doc = #docs] pub #names: f64,)*
        }

        impl Signals {
            /// The fields' names, in order.
            pub const NAMES: [&'static str; #k] = [#(#strings),*];

            /// The fields from an array in the order of [`Signals::NAMES`].
            #[must_use]
            pub fn from_array(a: [f64; #k]) -> Self {
                let [#(#names),*] = a;
                Signals { #(#names),* }
            }

            /// The fields as an array in the order of [`Signals::NAMES`].
            #[must_use]
            pub fn to_array(&self) -> [f64; #k] {
                [#(self.#names),*]
            }
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
            let bits = comp.signature(c.arrs.len());
            let (db, ib) = (comp.detectable, comp.isolable);
            quote! {
                ::bondgraph::Component {
                    name: #name,
                    kind: #kind,
                    signature: &[#(#bits),*],
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
        pub fn candidates(alarms: &[bool; #n]) -> Vec<&'static str> {
            FSM.candidates(alarms)
        }

        /// The components whose fault is consistent with the residuals in alarm, with no
        /// exoneration (see [`bondgraph::Fsm::suspects`]).
        #[must_use]
        pub fn suspects(alarms: &[bool; #n]) -> Vec<&'static str> {
            FSM.suspects(alarms)
        }
    }
}

/// The streaming generator: raw samples in, residuals out.
fn generator(
    c: &Compiled,
    readings: &Readings,
    fields: &[Field],
    lower: &Lowering<'_>,
    copy: Option<&CopyLeaves>,
) -> TokenStream {
    let raw: BTreeMap<Signal, u32> = readings.raw.iter().copied().collect();
    let integrated = &readings.integrated;
    let others = &readings.nonlinear;
    let signal_name = |s: Signal| match s {
        Signal::Input(u) => c.inputs[u].name.clone(),
        Signal::Sensor(h) => c.sensors[h].name.clone(),
    };
    let raw_names: Vec<String> = raw.keys().map(|&s| signal_name(s)).collect();
    let raw_index: HashMap<Signal, usize> = raw.keys().enumerate().map(|(i, &s)| (s, i)).collect();
    let orders: Vec<u32> = raw.values().copied().collect();
    let order_literals: Vec<Literal> = orders.iter().map(|&n| Literal::u32_unsuffixed(n)).collect();
    let r = count(raw.len());
    let top = orders.iter().copied().max().unwrap_or(0);
    let top_literal = Literal::u32_unsuffixed(top);
    let i = count(integrated.len());
    let channels = count(raw.len() + integrated.len());
    // Channels: the raw signals whose derivatives are read, then the other raw signals, then
    // the integrals; the bank differentiates the first ones only.
    let differentiated = orders.iter().filter(|&&n| n > 0).count();
    let mut channel_of_raw = vec![0; orders.len()];
    let ranked = (0..orders.len()).filter(|&k| orders[k] > 0);
    for (channel, k) in ranked
        .chain((0..orders.len()).filter(|&k| orders[k] == 0))
        .enumerate()
    {
        channel_of_raw[k] = channel;
    }
    let differentiated_literal = count(differentiated);
    // The bank's estimates by order, bound by a slice pattern that cannot panic.
    let by_order: Vec<Ident> = (0..=top).map(|k| format_ident!("e{}", k)).collect();
    let raw_slots: Vec<Literal> = (0..raw.len()).map(count).collect();
    let raw_channels: Vec<Literal> = channel_of_raw.iter().map(|&c| count(c)).collect();
    let integral_slots: Vec<Literal> = (0..integrated.len())
        .map(|k| count(raw.len() + k))
        .collect();
    let integral_index: Vec<Literal> = (0..integrated.len()).map(count).collect();
    let integrated_raw: Vec<Literal> = integrated.iter().map(|s| count(raw_index[s])).collect();
    // How each field is filled from the estimates: `e{order}[channel]`.
    let fill: Vec<TokenStream> = fields
        .iter()
        .map(|f| {
            let name = ident(&f.name);
            match f.quantity {
                Quantity::Derivative(s, n) => {
                    let channel = count(channel_of_raw[raw_index[&s]]);
                    let order = format_ident!("e{}", n);
                    quote!(s.#name = #order[#channel];)
                }
                Quantity::Integral(s) => {
                    let k = integrated.iter().position(|&x| x == s).unwrap_or(0);
                    let channel = count(raw.len() + k);
                    quote!(s.#name = e0[#channel];)
                }
                Quantity::Nonlinear(_) | Quantity::Simulated(_) => quote!(),
            }
        })
        .collect();
    let o = count(others.len());
    // Inside `push`, none of `residuals`' `let`s exist: a lowering of its own.
    let fresh = Lowering {
        c,
        field: lower.field.clone(),
        copy: None,
        bound: HashMap::new(),
        auxiliary: HashMap::new(),
        others: Vec::new(),
    };
    let integrands: Vec<TokenStream> = others.iter().map(|&e| fresh.expr(e).0).collect();
    let other_fields: Vec<Ident> = (0..others.len())
        .map(|k| format_ident!("int{}", k + 1))
        .collect();
    let other_index: Vec<Literal> = (0..others.len()).map(count).collect();
    let mut channel_orders = vec![0; raw.len() + integrated.len()];
    for (k, &n) in orders.iter().enumerate() {
        channel_orders[channel_of_raw[k]] = n;
    }
    let channel_orders: Vec<Literal> = channel_orders
        .into_iter()
        .map(Literal::u32_unsuffixed)
        .collect();
    // The residuals realised by integration, each with its reference.
    let integrated: Vec<Literal> = (c.arrs.iter().enumerate())
        .filter(|(_, a)| matches!(a.realisation, Realisation::Integrated(_)))
        .map(|(k, _)| count(k))
        .collect();
    let references = count(integrated.len());
    let reference_index: Vec<Literal> = (0..integrated.len()).map(count).collect();
    let (copy_field, copy_init, copy_push, copy_read) = match copy {
        None => Default::default(),
        Some(copy) => {
            let inputs: Vec<Literal> = (copy.inputs.iter())
                .map(|&u| count(raw_index.get(&Signal::Input(u)).copied().unwrap_or(0)))
                .collect();
            let (hats, slots): (Vec<Ident>, Vec<Literal>) = (fields.iter())
                .filter_map(|f| match f.quantity {
                    Quantity::Simulated(k) => Some((ident(&f.name), count(k.index()))),
                    _ => None,
                })
                .unzip();
            (
                quote!(copy: ::bondgraph::Replay,),
                quote!(copy: ::bondgraph::Replay::new(&[0.0; COPY_STATES]),),
                quote! {
                    let params = self.params;
                    self.copy.push(t, &[#(raw[#inputs]),*], |t, x, u, dx| {
                        copy_rates(&params, t, x, u, dx)
                    });
                },
                quote! {
                    let xh = self.copy.at(at)?;
                    #(s.#hats = xh[#slots];)*
                },
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
            references: [::bondgraph::Reference; #references],
            #copy_field
            last: Signals,
        }

        impl<B: ::bondgraph::Bank<CHANNELS>> ResidualGenerator<B> {
            /// A generator over `bank`, which must estimate derivatives up to the highest
            /// order of [`CHANNEL_ORDERS`].
            pub fn with_bank(params: Params, bank: B) -> Result<Self, ::bondgraph::EstimatorError> {
                if bank.order() < #top_literal {
                    return Err(::bondgraph::EstimatorError::Order {
                        order: bank.order(),
                        needed: #top_literal,
                    });
                }
                Ok(ResidualGenerator {
                    params,
                    bank,
                    integrals: [::bondgraph::Trapezoid::new(); #i],
                    others: [::bondgraph::Trapezoid::new(); #o],
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
                #(x[#raw_channels] = raw[#raw_slots];)*
                #(
                    x[#integral_slots] =
                        self.integrals[#integral_index].push(t, raw[#integrated_raw]);
                )*
                let at = t - self.bank.delay();
                let [#(#by_order,)* ..] = self.bank.push(x)? else {
                    return None;
                };
                let mut s = Signals::default();
                #(#fill)*
                #copy_read
                let p = &self.params;
                #(
                    s.#other_fields = self.others[#other_index].push(at, { #integrands });
                )*
                let mut r = residuals(p, &s);
                #(r[#integrated] = self.references[#reference_index].push(r[#integrated]);)*
                self.last = s;
                Some(r)
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
}
