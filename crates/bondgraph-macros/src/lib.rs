//! `bond_graph!`: compiles a bond-graph model at build time into the module that
//! `bgc MODEL --emit rust` writes (re-exported by the `bondgraph` crate, which the generated
//! code calls).
//!
//! ```ignore
//! bondgraph::bond_graph!("models/backlash_bench.bg"); // relative to CARGO_MANIFEST_DIR
//! bondgraph::bond_graph! {
//!     model rc
//!     param R1 = 2
//!     ...
//! }
//! ```
//!
//! Either expands to `pub mod MODEL_NAME { ... }`. A model with an error is a compile error
//! naming the file, line and column of the first one.

use std::path::{Path, PathBuf};

use bondgraph_core::diagnostic::{Diagnostics, LineIndex};
use bondgraph_core::{compile, Options};
use proc_macro::{Delimiter, TokenStream, TokenTree};
use quote::quote;

/// Compiles the model at the path given (relative to the calling crate's
/// `CARGO_MANIFEST_DIR`) or written inline into its residual code, as `pub mod NAME { ... }`.
#[proc_macro]
pub fn bond_graph(input: TokenStream) -> TokenStream {
    match expand(input) {
        Ok(ts) | Err(ts) => ts.into(),
    }
}

/// The model's text, the name its diagnostics use, and the file to track for rebuilds.
struct Source {
    text: String,
    name: String,
    path: Option<PathBuf>,
}

fn expand(input: TokenStream) -> Result<proc_macro2::TokenStream, proc_macro2::TokenStream> {
    let call = proc_macro2::Span::call_site();
    let fail = |message: String| {
        let message = syn::LitStr::new(&message, call);
        quote!(::core::compile_error!(#message);)
    };
    let source = read(input).map_err(fail)?;
    let out = compile(&source.text, &source.name, &Options::default())
        .map_err(|d| fail(first_error(&source, &d)))?;
    let c = out.compiled;
    if c.has_errors() {
        return Err(fail(first_error(&source, &c.diagnostics)));
    }
    let module = bondgraph_codegen::rust::ident(&c.name);
    let items = bondgraph_codegen::rust::tokens(&c);
    // Cargo rebuilds the calling crate when a file it `include_bytes!`es changes.
    let track = source.path.map(|p| {
        let p = p.to_string_lossy().into_owned();
        quote!(
            const _: &[u8] = include_bytes!(#p);
        )
    });
    Ok(quote! {
        #[doc = concat!("Residual code for the bond-graph model `", stringify!(#module), "`, by bgc.")]
        pub mod #module {
            #track
            #items
        }
    })
}

/// The first error (or, without one, the first diagnostic) as `FILE:LINE:COLUMN: message`.
fn first_error(source: &Source, diagnostics: &Diagnostics) -> String {
    let lines = LineIndex::new(&source.text);
    let all: Vec<_> = diagnostics.iter().collect();
    let first = all.iter().find(|d| d.is_error()).or_else(|| all.first());
    match first {
        Some(d) => {
            let at = lines.line_col(&source.text, d.span.start);
            let more = all
                .iter()
                .filter(|d| d.is_error())
                .count()
                .saturating_sub(1);
            let tail = match more {
                0 => String::new(),
                n => format!(
                    " (and {n} more error{}; `bgc check` lists them)",
                    if n == 1 { "" } else { "s" }
                ),
            };
            format!(
                "{}:{}:{}: {}{tail}",
                source.name, at.line, at.col, d.message
            )
        }
        None => format!("{}: the model could not be compiled", source.name),
    }
}

/// The model from a path literal or inline tokens.
fn read(input: TokenStream) -> Result<Source, String> {
    let tokens: Vec<TokenTree> = input.clone().into_iter().collect();
    if let [TokenTree::Literal(lit)] = tokens.as_slice() {
        if let Ok(path) = syn::parse_str::<syn::LitStr>(&lit.to_string()) {
            return from_file(&path.value());
        }
    }
    if tokens.is_empty() {
        return Err(
            "bond_graph! needs a model: a path in quotes (\"models/x.bg\") or the model itself"
                .to_string(),
        );
    }
    Ok(Source {
        text: inline(input),
        name: "inline model".to_string(),
        path: None,
    })
}

fn from_file(relative: &str) -> Result<Source, String> {
    let root = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".to_string());
    let path = Path::new(&root).join(relative);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        format!(
            "cannot read the model `{relative}` (looked for {}): {e}",
            path.display()
        )
    })?;
    Ok(Source {
        text,
        name: relative.to_string(),
        path: Some(path),
    })
}

/// The inline model's text, rebuilt with its line breaks and columns from the tokens'
/// positions: the model language ends statements at line ends, which tokens do not keep.
fn inline(input: TokenStream) -> String {
    let mut out = String::new();
    let mut at: Option<(usize, usize)> = None;
    let mut base = None;
    write_tokens(input, &mut out, &mut at, &mut base);
    out.push('\n');
    out
}

fn place(
    out: &mut String,
    at: &mut Option<(usize, usize)>,
    base: &mut Option<usize>,
    span: proc_macro::Span,
    text: &str,
) {
    let (line, column) = (span.line(), span.column());
    let base = *base.get_or_insert(column);
    match *at {
        Some((l, c)) if l == line => {
            if column > c {
                out.push_str(&" ".repeat(column - c));
            } else if !out.ends_with(' ') {
                out.push(' ');
            }
        }
        Some((l, _)) => {
            out.push_str(&"\n".repeat(line.saturating_sub(l).max(1)));
            out.push_str(&" ".repeat(column.saturating_sub(base)));
        }
        None => {}
    }
    out.push_str(text);
    *at = Some((line, column + text.chars().count()));
}

fn write_tokens(
    input: TokenStream,
    out: &mut String,
    at: &mut Option<(usize, usize)>,
    base: &mut Option<usize>,
) {
    for tt in input {
        match tt {
            TokenTree::Group(g) => {
                let (open, close) = match g.delimiter() {
                    Delimiter::Parenthesis => ("(", ")"),
                    Delimiter::Brace => ("{", "}"),
                    Delimiter::Bracket => ("[", "]"),
                    Delimiter::None => ("", ""),
                };
                place(out, at, base, g.span_open(), open);
                write_tokens(g.stream(), out, at, base);
                place(out, at, base, g.span_close(), close);
            }
            other => {
                let text = other.to_string();
                place(out, at, base, other.span(), &text);
            }
        }
    }
}
