//! `bond_graph!`: compiles a bond-graph model at build time into the module that
//! `bgc MODEL --emit rust` writes (re-exported by the `bondgraph` crate, which the generated
//! code calls).
//!
//! ```ignore
//! bondgraph::bond_graph!("models/backlash_bench.bg"); // relative to CARGO_MANIFEST_DIR
//! bondgraph::bond_graph!("models/dc_motor.bg", residuals = best); // as `--residuals best`
//! bondgraph::bond_graph!("models/dc_motor.bg", realise = direct); // as `--realise direct`
//! bondgraph::bond_graph!("models/dc_motor.bg", params = "fitted.params"); // as `--params`
//! bondgraph::bond_graph! {
//!     model rc
//!     param R1 = 2
//!     ...
//! }
//! ```
//!
//! Either expands to `pub mod MODEL_NAME { ... }`. A model with errors is a compile error for
//! each (up to ten), as `bgc check` shows them: for a file, its name, line and
//! column, the line with the offending text marked and what was expected there; inline, at
//! the offending token itself; and the help, when there is some.

use std::path::PathBuf;

use bondgraph_core::diagnostic::{Diagnostic, Diagnostics, LineIndex};
use bondgraph_core::{compile, Options, Realise, ResidualSet};
use proc_macro::{Delimiter, Spacing, TokenStream, TokenTree};
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
    /// For an inline model, where each token starts in `text`, and its span in the caller.
    tokens: Vec<(usize, proc_macro::Span)>,
    /// Which residuals to generate (`residuals = per_sensor | best | all | simulated` after a path).
    residuals: ResidualSet,
    /// How to realise them (`realise = lowest | direct` after a path).
    realise: Realise,
    /// The parameter file whose values replace the model's (`params = "FILE"` after a
    /// path), already applied to `text`.
    params: Option<PathBuf>,
}

fn expand(input: TokenStream) -> Result<proc_macro2::TokenStream, proc_macro2::TokenStream> {
    let call = proc_macro2::Span::call_site();
    let fail = |message: String| {
        let message = syn::LitStr::new(&message, call);
        quote!(::core::compile_error!(#message);)
    };
    let source = read(input).map_err(fail)?;
    let refuse = |d: &Diagnostics| -> proc_macro2::TokenStream {
        errors(&source, d)
            .into_iter()
            .map(|(message, offset)| {
                // Inline, the error points at the offending token itself.
                match source.tokens.iter().rev().find(|(at, _)| *at <= offset) {
                    Some((_, span)) if source.path.is_none() => {
                        let span: proc_macro2::Span = (*span).into();
                        let message = syn::LitStr::new(&message, span);
                        quote::quote_spanned!(span=> ::core::compile_error!(#message);)
                    }
                    _ => fail(message),
                }
            })
            .collect()
    };
    let options = Options {
        residuals: source.residuals,
        realise: source.realise,
        ..Options::default()
    };
    let out = compile(&source.text, &source.name, &options).map_err(|d| refuse(&d))?;
    let c = out.compiled;
    // Refused state equations alone leave the ARRs and their code as they are; anything else
    // refused would make code that misleads.
    if c.residual_code_refused() {
        return Err(refuse(&c.diagnostics));
    }
    let module = bondgraph_codegen::rust::ident(&c.name);
    let items = bondgraph_codegen::rust::tokens(&c)
        .map_err(|why| fail(format!("{}: cannot write Rust: {why}", source.name)))?;
    // Cargo rebuilds the calling crate when a file it `include_bytes!`es changes.
    let track = (source.path.iter().chain(&source.params)).map(|p| {
        let p = p.to_string_lossy().into_owned();
        quote!(
            const _: &[u8] = include_bytes!(#p);
        )
    });
    Ok(quote! {
        #[doc = concat!("Residual code for the bond-graph model `", stringify!(#module), "`, by bgc.")]
        pub mod #module {
            #(#track)*
            #items
        }
    })
}

/// How many of a model's errors become compile errors; `bgc check` lists the rest.
const MAX_SHOWN: usize = 10;

/// Each error (or, without one, the first diagnostic) as the compiler will show it, with its
/// offset in the text.
fn errors(source: &Source, diagnostics: &Diagnostics) -> Vec<(String, usize)> {
    let all: Vec<&Diagnostic> = diagnostics.iter().collect();
    let mut shown: Vec<&Diagnostic> = all.iter().copied().filter(|d| d.is_error()).collect();
    if shown.is_empty() {
        shown.extend(all.first());
    }
    if shown.is_empty() {
        return vec![(
            format!("{}: the model could not be compiled", source.name),
            0,
        )];
    }
    let more = shown.len().saturating_sub(MAX_SHOWN);
    let mut out: Vec<(String, usize)> = shown
        .iter()
        .take(MAX_SHOWN)
        .map(|d| (render(source, d), d.span.start))
        .collect();
    if more > 0 {
        let last = out.len() - 1;
        out[last].0.push_str(&format!(
            "\n  = note: {more} more error{}; `bgc check` lists them",
            if more == 1 { "" } else { "s" }
        ));
    }
    out
}

/// One diagnostic as a compile error's message. From a file, the compiler can only point at
/// the macro call, so the message carries `FILE:LINE:COLUMN`, the line and a caret under the
/// offending text, as `bgc check` does; inline, the compiler points at the token and the
/// message says what was expected there.
fn render(source: &Source, d: &Diagnostic) -> String {
    let text = &source.text;
    let lines = LineIndex::new(text);
    let at = lines.line_col(text, d.span.start);
    let mut out = match source.path {
        Some(_) => {
            let line = text.lines().nth(at.line - 1).unwrap_or("");
            let number = at.line.to_string();
            let pad = " ".repeat(number.len());
            let width = text
                .get(d.span.start..d.span.end)
                .map_or(1, |s| s.lines().next().unwrap_or("").chars().count().max(1));
            format!(
                "{}:{}:{}: {}\n{pad} |\n{number} | {line}\n{pad} | {}{} {}",
                source.name,
                at.line,
                at.col,
                d.message,
                " ".repeat(at.col - 1),
                "^".repeat(width),
                d.label
            )
        }
        None if d.label.is_empty() => format!("in the model: {}", d.message),
        None => format!("in the model: {}\n  = {}", d.message, d.label),
    };
    let trimmed = out.trim_end().len();
    out.truncate(trimmed);
    for note in &d.notes {
        let at = lines.line_col(text, note.span.start);
        out.push_str(&format!(
            "\n  = note: {} (line {}, column {})",
            note.message, at.line, at.col
        ));
    }
    if let Some(help) = &d.help {
        out.push_str(&format!("\n  = help: {help}"));
    }
    out
}

/// The model from a path literal or inline tokens.
fn read(input: TokenStream) -> Result<Source, String> {
    let tokens: Vec<TokenTree> = input.clone().into_iter().collect();
    if let [TokenTree::Literal(lit), rest @ ..] = tokens.as_slice() {
        if let Ok(path) = syn::parse_str::<syn::LitStr>(&lit.to_string()) {
            let settings = settings(rest)?;
            let source = from_file(&path.value())?;
            return with_params(source, settings.params.as_deref()).map(|s| Source {
                residuals: settings.residuals,
                realise: settings.realise,
                ..s
            });
        }
    }
    if tokens.is_empty() {
        return Err(
            "bond_graph! needs a model: a path in quotes (\"models/x.bg\") or the model itself"
                .to_string(),
        );
    }
    let (text, tokens) = inline(input);
    Ok(Source {
        text,
        name: "inline model".to_string(),
        path: None,
        tokens,
        residuals: ResidualSet::PerSensor,
        realise: Realise::Lowest,
        params: None,
    })
}

/// What may follow a model's path.
struct Settings {
    residuals: ResidualSet,
    realise: Realise,
    /// The parameter file's path as written (relative to the same directory as the model's).
    params: Option<String>,
}

/// What follows the path: nothing, or `, residuals = per_sensor | best | all | simulated`,
/// `, realise = lowest | direct`, `, params = "FILE"`.
fn settings(rest: &[TokenTree]) -> Result<Settings, String> {
    let text: Vec<String> = rest.iter().map(ToString::to_string).collect();
    let words: Vec<&str> = text.iter().map(String::as_str).collect();
    let mut out = Settings {
        residuals: ResidualSet::PerSensor,
        realise: Realise::Lowest,
        params: None,
    };
    let expected = || {
        format!(
            "after the model's path, expected nothing or `, residuals = per_sensor | best | all | simulated`, \
             `, realise = lowest | direct` and `, params = \"FILE\"`, found `{}`",
            words.join(" ")
        )
    };
    for setting in words.chunks(4) {
        match setting {
            [",", "params", "=", file] => {
                let file = syn::parse_str::<syn::LitStr>(file).map_err(|_| {
                    format!("`params = {file}`: expected the parameter file's path in quotes")
                })?;
                out.params = Some(file.value());
            }
            [",", "residuals", "=", set] => {
                out.residuals = match *set {
                    "per_sensor" => ResidualSet::PerSensor,
                    "best" => ResidualSet::Best,
                    "all" => ResidualSet::All,
                    "simulated" => ResidualSet::Simulated,
                    "partial" => ResidualSet::Partial,
                    "bank" => ResidualSet::Bank,
                    other => {
                        return Err(format!(
                    "`residuals = {other}`: expected `per_sensor`, `best`, `all`, `simulated`, `partial` or `bank`"
                ))
                    }
                }
            }
            [",", "realise", "=", how] => {
                out.realise = match *how {
                    "lowest" => Realise::Lowest,
                    "direct" => Realise::Direct,
                    other => {
                        return Err(format!(
                        "`realise = {other}`: expected `lowest` (the ARRs integrated once where \
                             that lowers the derivatives they read) or `direct` (as written)"
                    ))
                    }
                }
            }
            _ => return Err(expected()),
        }
    }
    Ok(out)
}

/// `source` with the values of the parameter file at `relative` (resolved as the model's
/// path is) in place of the model's: its lines and columns stay, so that a diagnostic points
/// where it would in the model; a bad file is refused at its own line and column.
fn with_params(source: Source, relative: Option<&str>) -> Result<Source, String> {
    let Some(relative) = relative else {
        return Ok(source);
    };
    let path = root().join(relative);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        format!(
            "cannot read the parameter file `{relative}` (looked for {}): {e}",
            path.display()
        )
    })?;
    let values =
        bondgraph_core::ParameterValues::parse(&text).map_err(|e| format!("{relative}:{e}"))?;
    let replaced = values
        .apply(&source.text)
        .map_err(|e| format!("{relative}:{e}"))?;
    Ok(Source {
        text: replaced,
        params: Some(path),
        ..source
    })
}

/// The directory model and parameter paths are relative to.
fn root() -> PathBuf {
    PathBuf::from(
        std::env::var(ROOT_OVERRIDE)
            .or_else(|_| std::env::var("CARGO_MANIFEST_DIR"))
            .unwrap_or_else(|_| ".".to_string()),
    )
}

/// Overrides the directory model paths are relative to: trybuild compiles its cases in a
/// crate of its own, whose `CARGO_MANIFEST_DIR` is not the one the paths were written for.
const ROOT_OVERRIDE: &str = "BOND_GRAPH_ROOT";

fn from_file(relative: &str) -> Result<Source, String> {
    let path = root().join(relative);
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
        tokens: Vec::new(),
        residuals: ResidualSet::PerSensor,
        realise: Realise::Lowest,
        params: None,
    })
}

/// The inline model's text, rebuilt with its line breaks from the tokens' lines (the model
/// language ends statements at line ends, which tokens do not keep); tokens on one line are
/// separated by a space, except after a joint punctuation (`->`). With it, where each token
/// starts in the text and its span.
fn inline(input: TokenStream) -> (String, Vec<(usize, proc_macro::Span)>) {
    let mut w = Writer::default();
    w.tokens(input);
    w.out.push('\n');
    (w.out, w.spans)
}

/// Writes tokens back as text.
#[derive(Default)]
struct Writer {
    out: String,
    spans: Vec<(usize, proc_macro::Span)>,
    line: Option<usize>,
    joint: bool,
}

impl Writer {
    fn place(&mut self, span: proc_macro::Span, text: &str, joint_before: bool) {
        let line = span.line();
        match self.line {
            Some(l) if l < line => self.out.push_str(&"\n".repeat(line - l)),
            Some(_) if !joint_before => self.out.push(' '),
            _ => {}
        }
        self.spans.push((self.out.len(), span));
        self.out.push_str(text);
        self.line = Some(self.line.map_or(line, |l| l.max(line)));
    }

    fn tokens(&mut self, input: TokenStream) {
        for tt in input {
            match tt {
                TokenTree::Group(g) => {
                    let (open, close) = match g.delimiter() {
                        Delimiter::Parenthesis => ("(", ")"),
                        Delimiter::Brace => ("{", "}"),
                        Delimiter::Bracket => ("[", "]"),
                        Delimiter::None => ("", ""),
                    };
                    self.place(g.span_open(), open, self.joint);
                    self.joint = true;
                    self.tokens(g.stream());
                    self.place(g.span_close(), close, true);
                    self.joint = false;
                }
                TokenTree::Punct(p) => {
                    self.place(p.span(), &p.to_string(), self.joint);
                    self.joint = p.spacing() == Spacing::Joint;
                }
                other => {
                    self.place(other.span(), &other.to_string(), self.joint);
                    self.joint = false;
                }
            }
        }
    }
}
