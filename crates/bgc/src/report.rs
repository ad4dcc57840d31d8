//! What bgc says on standard error, all through one miette renderer: the model's
//! diagnostics (file:line:col, the source line, what was expected) and the command's own
//! errors and warnings; and why a command stops without success.

use std::fmt;
use std::process::ExitCode;

use bondgraph_core::diagnostic::{self, Code, Diagnostic, Diagnostics, Severity, Span};
use bondgraph_core::{without_bom, Options, Output};
use miette::{LabeledSpan, MietteHandlerOpts, NamedSource, SourceSpan};

/// Sets how reports look: no terminal hyperlinks (they break copy-paste and snapshots); a fixed
/// width and character set, so output does not depend on the terminal it was produced on.
/// Colour still follows the terminal and `NO_COLOR`.
pub(crate) fn install_hook() {
    // Fails only if a hook is already set, in which case that one is kept.
    let _ = miette::set_hook(Box::new(|_| {
        Box::new(
            MietteHandlerOpts::new()
                .terminal_links(false)
                .unicode(true)
                .width(100)
                .build(),
        )
    }));
}

/// Why bgc stops without success.
pub(crate) enum Failure {
    /// The model (or a record, a scenario) has errors, or an output was refused; they were
    /// reported.
    Invalid,
    /// Arguments or files were wrong; the reason was reported.
    Usage,
}

impl Failure {
    /// The process exit code for this failure.
    pub(crate) fn exit_code(&self) -> ExitCode {
        match self {
            Failure::Invalid => ExitCode::from(1),
            Failure::Usage => ExitCode::from(2),
        }
    }
}

/// Reports a usage error (bad arguments, a file that cannot be read or written): exit 2.
pub(crate) fn usage(message: impl fmt::Display) -> Failure {
    say(Said::new(miette::Severity::Error, "bgc::usage", message));
    Failure::Usage
}

/// Reports why a command refused its input (a record, a scenario, a failed check): exit 1.
pub(crate) fn refused(message: impl fmt::Display) -> Failure {
    say(Said::new(miette::Severity::Error, "bgc::refused", message));
    Failure::Invalid
}

/// Reports what the user should know about an output that was still written.
pub(crate) fn warn(message: impl fmt::Display) {
    say(Said::new(
        miette::Severity::Warning,
        "bgc::warning",
        message,
    ));
}

/// Reports what a command chose or found, for the user to read (not a diagnostic).
pub(crate) fn note(message: impl fmt::Display) {
    eprintln!("note: {message}");
}

fn say(said: Said) {
    use std::io::Write as _;
    // In one piece: the renderer writes a report in many small parts.
    let text = format!("{:?}\n", miette::Report::new(said));
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

/// A command's own error or warning, with no source to point into.
struct Said {
    severity: miette::Severity,
    code: &'static str,
    message: String,
}

impl Said {
    fn new(severity: miette::Severity, code: &'static str, message: impl fmt::Display) -> Said {
        Said {
            severity,
            code,
            message: short_words(&message.to_string()),
        }
    }
}

impl fmt::Debug for Said {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl fmt::Display for Said {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Said {}

impl miette::Diagnostic for Said {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(self.severity)
    }
}

/// Compiles a model from raw bytes, printing every diagnostic; `None` if the model is invalid.
pub(crate) fn compile(name: &str, bytes: Vec<u8>, options: &Options) -> Option<Output> {
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => {
            let (text, diagnostics) = not_text(&e);
            print(name, &text, &diagnostics);
            return None;
        }
    };
    let text = without_bom(&text);
    match bondgraph_core::compile(text, name, options) {
        Ok(out) => {
            print(name, text, &out.compiled.diagnostics);
            Some(out)
        }
        Err(diagnostics) => {
            print(name, text, &diagnostics);
            None
        }
    }
}

/// The diagnostic for a file that is not UTF-8, located at its first bad byte.
fn not_text(e: &std::string::FromUtf8Error) -> (String, Diagnostics) {
    let at = e.utf8_error().valid_up_to();
    let byte = e.as_bytes().get(at).copied().unwrap_or(0);
    // Show the text up to the bad byte, then a replacement character standing for it: the rest
    // of a binary file is noise on a terminal.
    let valid = String::from_utf8_lossy(&e.as_bytes()[..at]);
    let text = format!("{valid}\u{FFFD}");
    let mut diagnostics = Diagnostics::default();
    diagnostics.push(
        Diagnostic::error(
            Code::NotText,
            Span::new(at, at + 3),
            "the file is not UTF-8 text",
        )
        .with_label(format!("found byte 0x{byte:02X}; expected UTF-8 text"))
        .with_help("a .bg model is a text file; check that this is the right file"),
    );
    (text, diagnostics)
}

/// How many diagnostics of a kind are printed in full: past it, a count. A generated or
/// damaged model can hold thousands of errors (a group bond of 100 sources into 100
/// resistors gave 14 MB of them); the first ones say what is wrong.
pub(crate) const MOST_SHOWN: usize = 50;

/// How many places besides its own one diagnostic points at.
const MOST_LABELS: usize = 8;

/// Prints each diagnostic against `text` (named `name`), in order, at most
/// [`MOST_SHOWN`] of each severity, then a count of those left out and of the errors. The
/// source is shared and its lines indexed once, and each report is written in one piece:
/// many diagnostics on a large file cost what they print, not the file's size each.
pub(crate) fn print(name: &str, text: &str, diagnostics: &Diagnostics) {
    use std::io::Write as _;
    let source: std::sync::Arc<str> = std::sync::Arc::from(text);
    let lines = diagnostic::LineIndex::new(text);
    let mut out = String::new();
    let mut shown = [0usize; 2];
    for d in diagnostics.iter() {
        let kind = usize::from(d.severity == Severity::Warning);
        shown[kind] += 1;
        if shown[kind] > MOST_SHOWN {
            continue;
        }
        let mut d = shortened(d);
        // One error pointing at every bond of a long group line quoted each of them.
        if d.notes.len() > MOST_LABELS {
            let left = d.notes.len() - MOST_LABELS;
            d.notes.truncate(MOST_LABELS);
            let more = format!("and {left} more place{} like these", plural(left));
            d.help = Some(match d.help.take() {
                Some(help) => format!("{help}\n{more}"),
                None => more,
            });
        }
        let report = Report {
            at: lines.line_col(text, d.span.start).to_string(),
            diagnostic: d,
            source: NamedSource::new(name, std::sync::Arc::clone(&source)),
        };
        out.push_str(&format!("{:?}\n", miette::Report::new(report)));
    }
    let errors = diagnostics.error_count();
    let warnings = diagnostics.len() - errors;
    for (count, what) in [(errors, "error"), (warnings, "warning")] {
        if count > MOST_SHOWN {
            let left = count - MOST_SHOWN;
            out.push_str(&format!(
                "bgc: {name}: and {left} more {what}{}\n",
                plural(left)
            ));
        }
    }
    if errors > 0 {
        out.push_str(&format!(
            "bgc: {name}: {errors} error{}{}\n",
            plural(errors),
            if warnings > 0 {
                format!(", {warnings} warning{}", plural(warnings))
            } else {
                String::new()
            }
        ));
    }
    let _ = std::io::stderr().lock().write_all(out.as_bytes());
}

/// The longest name a diagnostic repeats whole: a 70,000-character name was written out
/// three times per error (in the message, its label and its help).
const LONGEST_NAME: usize = 200;

/// `d` with every word longer than [`LONGEST_NAME`] cut to its start, its end and its length.
fn shortened(d: &Diagnostic) -> Diagnostic {
    let mut d = d.clone();
    d.message = short_words(&d.message);
    d.help = d.help.as_deref().map(short_words);
    d.label = short_words(&d.label);
    for note in &mut d.notes {
        note.message = short_words(&note.message);
    }
    d
}

/// `text` with each run of letters, digits and `_` longer than [`LONGEST_NAME`] written as
/// its first 60 characters, `…`, its last 20 and its length.
fn short_words(text: &str) -> String {
    if text.len() <= LONGEST_NAME {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len().min(4 * LONGEST_NAME));
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let n = word.chars().count();
        if n > LONGEST_NAME {
            let head: String = word.chars().take(60).collect();
            let tail: String = word.chars().skip(n - 20).collect();
            out.push_str(&format!("{head}…{tail} ({n} characters)"));
        } else {
            out.push_str(word);
        }
        word.clear();
    };
    for c in text.chars() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// One core diagnostic with the source it points into.
struct Report {
    /// Where it points, as `line:col`.
    at: String,
    diagnostic: Diagnostic,
    source: NamedSource<std::sync::Arc<str>>,
}

impl fmt::Debug for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.diagnostic.message)
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {}",
            self.source.name(),
            self.at,
            self.diagnostic.message
        )
    }
}

impl std::error::Error for Report {}

/// The longest line a diagnostic quotes: past it, the message and its `file:line:col` only.
/// A snippet of a longer line helps no reader, and the renderer cannot lay out columns past
/// 65,535 (it panicked there).
const WIDEST_QUOTED_LINE: usize = 4_000;

impl Report {
    /// Whether a line the diagnostic points into is too long to quote.
    fn too_wide(&self) -> bool {
        let text = self.source.inner().as_bytes();
        let d = &self.diagnostic;
        (std::iter::once(d.span).chain(d.notes.iter().map(|n| n.span))).any(|span| {
            let at = span.start.min(text.len());
            let start = text[..at]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |k| k + 1);
            let end = (text[at..].iter())
                .position(|&b| b == b'\n')
                .map_or(text.len(), |k| at + k);
            end - start > WIDEST_QUOTED_LINE
        })
    }
}

fn source_span(span: Span) -> SourceSpan {
    SourceSpan::new(span.start.into(), span.len())
}

impl miette::Diagnostic for Report {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.diagnostic.code.as_str()))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(match self.diagnostic.severity {
            Severity::Error => miette::Severity::Error,
            Severity::Warning => miette::Severity::Warning,
        })
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic
            .help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        (!self.too_wide()).then_some(&self.source as &dyn miette::SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        if self.too_wide() {
            return None;
        }
        let d = &self.diagnostic;
        let label = (!d.label.is_empty()).then(|| d.label.clone());
        let primary = LabeledSpan::new_primary_with_span(label, source_span(d.span));
        let notes = d
            .notes
            .iter()
            .map(|n| LabeledSpan::new_with_span(Some(n.message.clone()), source_span(n.span)));
        Some(Box::new(std::iter::once(primary).chain(notes)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_past_200_characters_is_cut_to_its_ends_and_length() {
        let long = "m".to_string() + &"x".repeat(70_000);
        let said = short_words(&format!("`{long}` is not defined"));
        assert!(said.len() < 200, "{said}");
        assert!(
            said.ends_with("xxxx (70001 characters)` is not defined"),
            "{said}"
        );
        assert_eq!(short_words("`ab_c` is fine"), "`ab_c` is fine");
    }
}
