//! Diagnostics: what every stage reports about a model, always tied to a place in its source.
//!
//! A [`Diagnostic`] is plain data (no terminal, no colours): front ends render it, the CLI with
//! miette, the proc-macro as a compile error. Every diagnostic carries a [`Span`], so a user is
//! always told where the problem is.

use std::fmt;

/// A byte range `start..end` in one source text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Span {
    /// First byte of the range.
    pub start: usize,
    /// One past the last byte of the range.
    pub end: usize,
}

impl Span {
    /// The range `start..end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span {
            start,
            end: end.max(start),
        }
    }

    /// The same range moved `offset` bytes later (a statement's span into its file).
    pub fn shifted(self, offset: usize) -> Self {
        Span::new(self.start + offset, self.end + offset)
    }

    /// The smallest range covering both.
    pub fn to(self, other: Span) -> Self {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    /// Length in bytes.
    pub fn len(self) -> usize {
        self.end - self.start
    }

    /// Whether the range is empty (a position rather than a stretch of text).
    pub fn is_empty(self) -> bool {
        self.end == self.start
    }
}

/// How bad a diagnostic is: errors stop the pipeline, warnings do not.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The model is usable; the user may still want to look.
    Warning,
    /// The model is rejected.
    Error,
}

/// Stable identifiers of every kind of diagnostic, so users and tests can refer to them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Code {
    /// The file is not UTF-8 text.
    NotText,
    /// The text does not follow the grammar.
    Syntax,
    /// No `model NAME` line, or more than one.
    ModelName,
    /// A name declared twice in one namespace.
    Duplicate,
    /// A name that is not declared.
    Undefined,
    /// An element kind that does not exist.
    UnknownKind,
    /// A function that does not exist, or called with the wrong number of arguments.
    BadCall,
    /// A parameter without a value.
    MissingValue,
    /// An element declared with a law its kind cannot have.
    BadLaw,
    /// A name used where its kind of value is not allowed (a signal in a constant modulus…).
    BadReference,
    /// `let` definitions that depend on each other in a cycle.
    Cycle,
    /// A bond number used twice, or a numbered arrow that makes several bonds.
    BondNumber,
    /// A bond that cannot exist (a node bonded to itself, power into a detector…).
    BadBond,
    /// An element or junction with the wrong number of bonds.
    PortCount,
    /// A bond whose power direction breaks the element's convention.
    Direction,
    /// A detector attached where it cannot measure.
    Detector,
    /// A declaration that nothing uses.
    Unused,
    /// A name the language keeps for itself (`t`).
    Reserved,
    /// A value that is not a finite number.
    BadValue,
    /// A model with nothing in it.
    Empty,
    /// Two sources (or a source and a storage element) impose the same variable.
    Conflict,
    /// Algebraic equations that set each other and cannot be solved in closed form.
    AlgebraicLoop,
    /// Unknowns that nothing known determines.
    Underdetermined,
    /// A storage element that cannot take the causality its mode needs.
    Causality,
    /// A law that cannot be inverted in the direction causality needs.
    NotInvertible,
    /// A storage element kept in integral causality in diagnosis: the ARRs read the integrals
    /// of the signals that set it (a warning).
    MixedCausality,
    /// A parameter that several components read: a change of it faults them all at once.
    SharedParameter,
    /// A detector that yields no ARR, or ARRs that could not be written.
    NoArr,
    /// An output bgc refuses to write because it could not be derived.
    Refused,
    /// An expression whose expansion passes bgc's size bound.
    TooLarge,
}

impl Code {
    /// The short identifier printed with the diagnostic, e.g. `bg::syntax`.
    pub fn as_str(self) -> &'static str {
        match self {
            Code::NotText => "bg::not-text",
            Code::Syntax => "bg::syntax",
            Code::ModelName => "bg::model-name",
            Code::Duplicate => "bg::duplicate",
            Code::Undefined => "bg::undefined",
            Code::UnknownKind => "bg::unknown-kind",
            Code::BadCall => "bg::bad-call",
            Code::MissingValue => "bg::missing-value",
            Code::BadLaw => "bg::bad-law",
            Code::BadReference => "bg::bad-reference",
            Code::Cycle => "bg::cycle",
            Code::BondNumber => "bg::bond-number",
            Code::BadBond => "bg::bad-bond",
            Code::PortCount => "bg::port-count",
            Code::Direction => "bg::direction",
            Code::Detector => "bg::detector",
            Code::Unused => "bg::unused",
            Code::Reserved => "bg::reserved",
            Code::BadValue => "bg::bad-value",
            Code::Empty => "bg::empty",
            Code::Conflict => "bg::causal-conflict",
            Code::AlgebraicLoop => "bg::algebraic-loop",
            Code::Underdetermined => "bg::under-determined",
            Code::Causality => "bg::causality",
            Code::NotInvertible => "bg::not-invertible",
            Code::MixedCausality => "bg::mixed-causality",
            Code::SharedParameter => "bg::shared-parameter",
            Code::NoArr => "bg::no-arr",
            Code::Refused => "bg::refused",
            Code::TooLarge => "bg::too-large",
        }
    }
}

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A secondary place in the source that explains a diagnostic (e.g. the first declaration).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Note {
    /// Where.
    pub span: Span,
    /// What is there.
    pub message: String,
}

/// One problem found in a model, with where it is and what was expected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// Which kind of problem.
    pub code: Code,
    /// One sentence saying what is wrong.
    pub message: String,
    /// The offending text.
    pub span: Span,
    /// Short text shown under the offending text: usually what was expected there.
    pub label: String,
    /// Other places that explain this one.
    pub notes: Vec<Note>,
    /// How to fix it, when there is something useful to say.
    pub help: Option<String>,
}

impl Diagnostic {
    /// An error at `span`.
    pub fn error(code: Code, span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Error,
            code,
            message: message.into(),
            span,
            label: String::new(),
            notes: Vec::new(),
            help: None,
        }
    }

    /// A warning at `span`.
    pub fn warning(code: Code, span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(code, span, message)
        }
    }

    /// Sets the label shown under the offending text.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// Adds a secondary place.
    pub fn with_note(mut self, span: Span, message: impl Into<String>) -> Self {
        self.notes.push(Note {
            span,
            message: message.into(),
        });
        self
    }

    /// Sets the advice on how to fix it.
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// Whether this diagnostic rejects the model.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// The diagnostics a stage collected, in source order once sorted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Diagnostics(Vec<Diagnostic>);

impl Diagnostics {
    /// Records one diagnostic.
    pub fn push(&mut self, diagnostic: Diagnostic) {
        self.0.push(diagnostic);
    }

    /// Whether any error was recorded.
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(Diagnostic::is_error)
    }

    /// Number of errors recorded.
    pub fn error_count(&self) -> usize {
        self.0.iter().filter(|d| d.is_error()).count()
    }

    /// All diagnostics, in the order they were recorded.
    pub fn iter(&self) -> impl Iterator<Item = &Diagnostic> {
        self.0.iter()
    }

    /// Orders by position, so output does not depend on the order checks ran in.
    pub fn sort(&mut self) {
        self.0.sort_by(|a, b| {
            (a.span.start, a.span.end, a.code, &a.message).cmp(&(
                b.span.start,
                b.span.end,
                b.code,
                &b.message,
            ))
        });
    }

    /// Adds every diagnostic of another collection.
    pub fn extend(&mut self, other: Diagnostics) {
        self.0.extend(other.0);
    }

    /// Number of diagnostics.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The diagnostics as a vector.
    pub fn into_vec(self) -> Vec<Diagnostic> {
        self.0
    }
}

impl IntoIterator for Diagnostics {
    type Item = Diagnostic;
    type IntoIter = std::vec::IntoIter<Diagnostic>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

/// A 1-based line and column (in characters), as users count them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct LineCol {
    /// Line number, from 1.
    pub line: usize,
    /// Column in characters, from 1.
    pub col: usize,
}

impl fmt::Display for LineCol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

/// Byte offsets of line starts, to turn spans into lines and columns in O(log n).
#[derive(Clone, Debug)]
pub struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    /// Indexes `text`.
    pub fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// The line and column of byte `offset` in `text` (the text this index was built from).
    pub fn line_col(&self, text: &str, offset: usize) -> LineCol {
        let offset = offset.min(text.len());
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line];
        let col = text
            .get(start..offset)
            .map_or(offset - start, |s| s.chars().count());
        LineCol {
            line: line + 1,
            col: col + 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_from_one_and_in_characters() {
        let text = "ab\nπx\n\nz";
        let index = LineIndex::new(text);
        assert_eq!(index.line_col(text, 0), LineCol { line: 1, col: 1 });
        assert_eq!(index.line_col(text, 3), LineCol { line: 2, col: 1 });
        // 'x' comes after the two-byte 'π': byte 5, character column 2.
        assert_eq!(index.line_col(text, 5), LineCol { line: 2, col: 2 });
        assert_eq!(index.line_col(text, 7), LineCol { line: 3, col: 1 });
        assert_eq!(index.line_col(text, 8), LineCol { line: 4, col: 1 });
        assert_eq!(index.line_col(text, 99), LineCol { line: 4, col: 2 });
    }

    #[test]
    fn diagnostics_sort_by_position() {
        let mut all = Diagnostics::default();
        all.push(Diagnostic::error(Code::Syntax, Span::new(9, 10), "b"));
        all.push(Diagnostic::warning(Code::Unused, Span::new(1, 2), "a"));
        all.sort();
        let order: Vec<_> = all.iter().map(|d| d.message.as_str()).collect();
        assert_eq!(order, ["a", "b"]);
        assert!(all.has_errors());
        assert_eq!(all.error_count(), 1);
    }
}
