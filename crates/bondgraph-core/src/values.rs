//! Parameter files: the values `bgc identify` finds, as every command reads them, and a
//! model's text with its values replaced by them.
//!
//! A parameter file is text, one `NAME = VALUE` a line; `#` starts a comment (the interval
//! and the model's value `bgc identify` writes beside each estimate), blank lines are
//! skipped. A file names a parameter at most once, and only parameters the model declares:
//! a value that lands nowhere would be a silent mistake.

use std::fmt;

use crate::graph::closest;
use crate::syntax::{self, ast};

/// Parameter values read from a parameter file, in the file's order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParameterValues {
    entries: Vec<Entry>,
}

/// One `NAME = VALUE` line.
#[derive(Clone, Debug, PartialEq)]
struct Entry {
    name: String,
    value: f64,
    line: usize,
}

/// Why a parameter file cannot be read, or cannot be applied to a model; `line` and
/// `column` count from 1 in the parameter file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ValuesError {
    /// The line of the file.
    pub line: usize,
    /// The column of the line.
    pub column: usize,
    /// What is wrong, and what was expected.
    pub message: String,
}

impl fmt::Display for ValuesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.line, self.column, self.message)
    }
}

impl std::error::Error for ValuesError {}

impl ParameterValues {
    /// Reads a parameter file's text.
    pub fn parse(text: &str) -> Result<ParameterValues, ValuesError> {
        let mut entries: Vec<Entry> = Vec::new();
        for (k, raw) in crate::compile::without_bom(text).lines().enumerate() {
            let line = k + 1;
            let content = raw.split('#').next().unwrap_or("");
            if content.trim().is_empty() {
                continue;
            }
            let at = |offset: usize, message: String| ValuesError {
                line,
                column: raw[..offset].chars().count() + 1,
                message,
            };
            let indent = content.len() - content.trim_start().len();
            let Some(equals) = content.find('=') else {
                return Err(at(
                    indent,
                    format!("`{}`: expected `NAME = VALUE`", content.trim()),
                ));
            };
            let (name, value) = (content[..equals].trim(), &content[equals + 1..]);
            if !is_name(name) {
                return Err(at(
                    indent,
                    format!("`{name}` is not a parameter name (letters, digits, `_`)"),
                ));
            }
            let value_at = equals + 1 + (value.len() - value.trim_start().len());
            let number = value
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    at(
                        value_at.min(raw.len()),
                        format!("`{}`: expected a finite number", value.trim()),
                    )
                })?;
            if let Some(before) = entries.iter().find(|e| e.name == name) {
                return Err(at(
                    indent,
                    format!("`{name}` is given twice (first on line {})", before.line),
                ));
            }
            entries.push(Entry {
                name: name.to_string(),
                value: number,
                line,
            });
        }
        Ok(ParameterValues { entries })
    }

    /// Values by name, for a caller that builds them (`bgc identify`).
    pub fn from_pairs(pairs: impl IntoIterator<Item = (String, f64)>) -> ParameterValues {
        let entries = (pairs.into_iter().enumerate())
            .map(|(k, (name, value))| Entry {
                name,
                value,
                line: k + 1,
            })
            .collect();
        ParameterValues { entries }
    }

    /// Each name and value, in the file's order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> + '_ {
        self.entries.iter().map(|e| (e.name.as_str(), e.value))
    }

    /// The value given to `name`, if any.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.entries
            .iter()
            .find(|e| e.name == name)
            .map(|e| e.value)
    }

    /// How many values.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the file gives none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The model `source` with each parameter's value replaced by this file's, the rest of
    /// the text (comments, layout, units, uncertainties) as it was. A parameter the model
    /// does not declare is an error at its line of the file. A model that does not parse is
    /// returned as it is, for the compiler to report what is wrong with it.
    pub fn apply(&self, source: &str) -> Result<String, ValuesError> {
        let (file, diagnostics) = syntax::parse(source);
        if diagnostics.has_errors() {
            return Ok(source.to_string());
        }
        let declared: Vec<&ast::ParamDecl> = (file.statements.iter())
            .filter_map(|s| match &s.kind {
                ast::StatementKind::Param(p) => Some(p),
                _ => None,
            })
            .collect();
        let mut edits: Vec<(usize, usize, String)> = Vec::new();
        for entry in &self.entries {
            let Some(decl) = declared.iter().find(|d| d.name.name == entry.name) else {
                let names: Vec<&str> = declared.iter().map(|d| d.name.name.as_str()).collect();
                let hint = closest(&entry.name, names.iter().copied())
                    .map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
                return Err(ValuesError {
                    line: entry.line,
                    column: 1,
                    message: format!(
                        "the model declares no parameter `{}`{hint}; it declares {}",
                        entry.name,
                        names.join(", ")
                    ),
                });
            };
            let text = number(entry.value);
            edits.push(match decl.value {
                Some((_, span)) => (span.start, span.end, text),
                None => (decl.name.span.end, decl.name.span.end, format!(" = {text}")),
            });
        }
        edits.sort_by_key(|e| e.0);
        let mut out = String::with_capacity(source.len() + 16 * edits.len());
        let mut at = 0;
        for (start, end, text) in edits {
            out.push_str(&source[at..start]);
            out.push_str(&text);
            at = end;
        }
        out.push_str(&source[at..]);
        Ok(out)
    }
}

/// `v` in the shortest form that reads back to it, as the language writes numbers (`0.3`,
/// `1e-7`, `-2.5`).
fn number(v: f64) -> String {
    let shortest = format!("{v}");
    let exponent = format!("{v:e}");
    if exponent.len() < shortest.len() {
        exponent
    } else {
        shortest
    }
}

fn is_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "model m\n# the resistance\nparam R = 0.3 [Ohm] +- 5% \"resistance\"\nparam C = 2e-3\nparam k\n";

    #[test]
    fn values_replace_the_models_and_keep_the_rest_of_its_text() {
        let values = ParameterValues::parse("# fitted\nR = 0.31 # ± 0.01\n\n k = 1e-7\n")
            .expect("a good file");
        assert_eq!(values.get("R"), Some(0.31));
        let text = values.apply(MODEL).expect("declared");
        assert_eq!(
            text,
            "model m\n# the resistance\nparam R = 0.31 [Ohm] +- 5% \"resistance\"\nparam C = 2e-3\nparam k = 1e-7\n"
        );
    }

    #[test]
    fn a_bad_line_is_located_and_says_what_was_expected() {
        let e = ParameterValues::parse("R = 1\nC 2\n").expect_err("no =");
        assert_eq!((e.line, e.column), (2, 1));
        assert!(e.message.contains("NAME = VALUE"), "{e}");
        let e = ParameterValues::parse("R =  x1\n").expect_err("not a number");
        assert_eq!((e.line, e.column), (1, 6), "{e}");
        let e = ParameterValues::parse("R = 1\nR = 2\n").expect_err("twice");
        assert!(e.message.contains("first on line 1"), "{e}");
        let e = ParameterValues::parse("R = inf\n").expect_err("not finite");
        assert!(e.message.contains("finite"), "{e}");
    }

    #[test]
    fn a_value_for_no_declared_parameter_is_refused_with_a_hint() {
        let values = ParameterValues::parse("C = 1\nRr = 2\n").expect("parses");
        let e = values.apply(MODEL).expect_err("Rr is not declared");
        assert_eq!(e.line, 2);
        assert!(e.message.contains("did you mean `R`"), "{e}");
    }
}
