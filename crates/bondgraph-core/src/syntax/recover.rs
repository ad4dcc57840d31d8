//! What can still be read from a statement that does not parse: the names it declares.
//!
//! A declaration with a typo in its law still declares its name; without this, every later use
//! of the name would be reported as undefined, burying the one real error.

use super::ast::{Ident, Unparsed};
use crate::diagnostic::Span;

/// The words of `text` (a statement starting at byte `offset` of its file) that name things.
pub(crate) fn names(text: &str, offset: usize) -> Unparsed {
    let tokens = tokens(text);
    let ident = |t: &Token| Ident {
        name: text[t.start..t.end].to_string(),
        span: Span::new(t.start, t.end).shifted(offset),
    };
    let word = |i: usize| tokens.get(i).filter(|t| t.kind == Kind::Word);
    let junctions = tokens
        .windows(3)
        .filter(|w| {
            matches!(&text[w[0].start..w[0].end], "0" | "1")
                && &text[w[1].start..w[1].end] == ":"
                && w[2].kind == Kind::Word
        })
        .map(|w| ident(&w[2]))
        .collect();
    Unparsed {
        first: word(0).map(ident),
        name: word(0).and(word(1)).map(ident),
        junctions,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Word,
    Number,
    Punct,
}

struct Token {
    kind: Kind,
    start: usize,
    end: usize,
}

/// Words, numbers and single punctuation characters; comments and descriptions skipped.
fn tokens(text: &str) -> Vec<Token> {
    let mut out = Vec::new();
    let mut chars = text.char_indices().peekable();
    while let Some((start, c)) = chars.next() {
        let run = |chars: &mut std::iter::Peekable<std::str::CharIndices<'_>>,
                   keep: &dyn Fn(char) -> bool| {
            let mut end = start + c.len_utf8();
            while let Some(&(i, d)) = chars.peek() {
                if !keep(d) {
                    break;
                }
                end = i + d.len_utf8();
                chars.next();
            }
            end
        };
        match c {
            '#' => {
                run(&mut chars, &|d| d != '\n');
            }
            '"' => {
                run(&mut chars, &|d| d != '"' && d != '\n');
                chars.next();
            }
            c if c.is_whitespace() => {}
            c if c.is_ascii_alphabetic() || c == '_' => {
                let end = run(&mut chars, &|d| d.is_ascii_alphanumeric() || d == '_');
                out.push(Token {
                    kind: Kind::Word,
                    start,
                    end,
                });
            }
            c if c.is_ascii_digit() => {
                // One digit alone, so `0:` and `1:` stay recognisable.
                out.push(Token {
                    kind: Kind::Number,
                    start,
                    end: start + 1,
                });
            }
            c => out.push(Token {
                kind: Kind::Punct,
                start,
                end: start + c.len_utf8(),
            }),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> (Option<String>, Option<String>, Vec<String>) {
        let u = names(text, 0);
        (
            u.first.map(|i| i.name),
            u.name.map(|i| i.name),
            u.junctions.into_iter().map(|i| i.name).collect(),
        )
    }

    #[test]
    fn declarations_keep_their_names() {
        assert_eq!(
            read("Se U = sqr(U0)"),
            (Some("Se".into()), Some("U".into()), vec![])
        );
        assert_eq!(
            read("param Re = 1e999 # huge"),
            (Some("param".into()), Some("Re".into()), vec![])
        );
    }

    #[test]
    fn chains_keep_their_junctions_but_declare_nothing() {
        assert_eq!(
            read("U -> 1:elec -> 0:"),
            (Some("U".into()), None, vec!["elec".to_string()])
        );
    }
}
