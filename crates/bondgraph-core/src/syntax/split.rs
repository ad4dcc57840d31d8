//! Cuts a file into statements, so each can be parsed, and fail, on its own.
//!
//! A statement is one line, or several when a line ends with `->`, `<-` or `,` (a long chain
//! of bonds). `#` and `//` start a comment except inside a `"description"`.

use crate::diagnostic::Span;

/// The spans of the statements of `text`, in order; blank and comment-only lines are skipped.
pub(super) fn statements(text: &str) -> Vec<Span> {
    let mut out = Vec::new();
    let mut open: Option<usize> = None;
    let mut open_end = 0;
    let mut line_start = 0;
    while line_start < text.len() {
        let line_end = text[line_start..]
            .find('\n')
            .map_or(text.len(), |i| line_start + i);
        let code = code_part(&text[line_start..line_end]).trim_end();
        if !code.trim_start().is_empty() {
            let start = *open.get_or_insert(line_start + leading_blank(code));
            open_end = line_start + code.len();
            if !continues(code) {
                out.push(Span::new(start, line_start + code.len()));
                open = None;
            }
        }
        line_start = line_end + 1;
    }
    if let Some(start) = open {
        out.push(Span::new(start, open_end));
    }
    out
}

/// The line without its comment (`#`, or `//` as in the Rust around an inline model).
fn code_part(line: &str) -> &str {
    let mut in_string = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_string = !in_string,
            '#' if !in_string => return &line[..i],
            '/' if !in_string && line[i + 1..].starts_with('/') => return &line[..i],
            _ => {}
        }
    }
    line
}

fn leading_blank(code: &str) -> usize {
    code.len() - code.trim_start().len()
}

/// Whether a line's code asks for the next line to continue it.
fn continues(code: &str) -> bool {
    code.ends_with("->") || code.ends_with("<-") || code.ends_with(',')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pieces(text: &str) -> Vec<&str> {
        statements(text)
            .into_iter()
            .map(|s| &text[s.start..s.end])
            .collect()
    }

    #[test]
    fn one_statement_per_line_without_comments() {
        let text = "model m  # name\n\n  # only a comment\nR r = 1\n";
        let slashed = "model m  // name\n\n  // only a comment\nR r = 1\n";
        assert_eq!(pieces(slashed), ["model m", "R r = 1"]);
        assert_eq!(pieces(text), ["model m", "R r = 1"]);
    }

    #[test]
    fn arrows_and_commas_continue_a_statement() {
        let text = "a -> 1:j ->\n   b,\n   c\nd -> e";
        assert_eq!(pieces(text), ["a -> 1:j ->\n   b,\n   c", "d -> e"]);
    }

    #[test]
    fn a_hash_inside_a_description_is_text() {
        let text = "param K = 1 \"spring #2\" # real comment\n";
        assert_eq!(pieces(text), ["param K = 1 \"spring #2\""]);
    }

    #[test]
    fn a_dangling_continuation_ends_at_the_end_of_the_file() {
        let text = "a ->\n# nothing follows\n";
        assert_eq!(pieces(text), ["a ->"]);
    }

    #[test]
    fn windows_line_endings_stay_inside_the_statement_span() {
        let text = "model m\r\nR r = 1\r\n";
        assert_eq!(pieces(text), ["model m", "R r = 1"]);
    }
}
