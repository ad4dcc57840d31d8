//! What every part of the C printing shares: the model's names, the context, and how C
//! writes arrays, strings and comments.

use std::cell::Cell;
use std::fmt::Write as _;

use bondgraph_core::program::Program;
use bondgraph_core::Compiled;

use super::lower::{Lowering, Place};
use super::names::prefix;
use crate::rust::Unwritable;
use crate::signals::Field;

/// The names a model's C code declares, from its prefix.
pub(crate) struct Names {
    /// `backlash_bench`
    pub(crate) lower: String,
    /// `BACKLASH_BENCH`
    pub(crate) upper: String,
}

impl Names {
    pub(crate) fn new(c: &Compiled) -> Names {
        let lower = prefix(&c.name);
        Names {
            upper: lower.to_ascii_uppercase(),
            lower,
        }
    }

    /// `backlash_bench_NAME`
    pub(crate) fn f(&self, name: &str) -> String {
        format!("{}_{name}", self.lower)
    }

    /// `BACKLASH_BENCH_NAME`
    pub(crate) fn m(&self, name: &str) -> String {
        format!("{}_{name}", self.upper)
    }
}

/// What every part of the printing reads.
pub(crate) struct Context<'a> {
    pub(crate) c: &'a Compiled,
    pub(crate) program: &'a Program,
    pub(crate) fields: &'a [Field],
    pub(crate) names: &'a Names,
    pub(crate) refused: &'a Cell<Option<Unwritable>>,
    pub(crate) reads_sign: &'a Cell<bool>,
}

impl<'a> Context<'a> {
    pub(crate) fn lowering(&self, place: Place) -> Lowering<'a> {
        Lowering::new(
            self.c,
            self.program,
            self.fields,
            self.refused,
            self.reads_sign,
            place,
        )
    }

    pub(crate) fn residuals(&self) -> usize {
        self.program.residuals.len()
    }
}

/// An array's length in C, which has no empty arrays.
pub(crate) fn dim(n: usize) -> usize {
    n.max(1)
}

/// `s` as a C string literal.
pub(crate) fn string(s: &str) -> String {
    let mut out = String::from("\"");
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            ch if ch.is_ascii() && !ch.is_ascii_control() => out.push(ch),
            // Anything else as UTF-8 bytes, each in octal, which ends after three digits.
            ch => {
                let mut bytes = [0u8; 4];
                for b in ch.encode_utf8(&mut bytes).bytes() {
                    let _ = write!(out, "\\{b:03o}");
                }
            }
        }
    }
    out.push('"');
    out
}

/// `text` inside a C comment: a `*/` in a model's description would end it.
pub(crate) fn comment(text: &str) -> String {
    text.replace("*/", "* /")
}
