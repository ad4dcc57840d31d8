//! C identifiers for model names, chosen once for the header and the source.

/// C99's keywords, the names the generated code calls (libm's and its own), and the
/// object-like macros of `<math.h>` and `<float.h>` that a field or local must not be
/// expanded into.
const TAKEN: [&str; 77] = [
    "auto",
    "break",
    "case",
    "char",
    "const",
    "continue",
    "default",
    "do",
    "double",
    "else",
    "enum",
    "extern",
    "float",
    "for",
    "goto",
    "if",
    "inline",
    "int",
    "long",
    "register",
    "restrict",
    "return",
    "short",
    "signed",
    "sizeof",
    "static",
    "struct",
    "switch",
    "typedef",
    "union",
    "unsigned",
    "void",
    "volatile",
    "while",
    "_Bool",
    "_Complex",
    "_Imaginary",
    "exp",
    "log",
    "sqrt",
    "fabs",
    "sin",
    "cos",
    "tan",
    "tanh",
    "atan",
    "atanh",
    "pow",
    "fmin",
    "fmax",
    "isfinite",
    "HUGE_VAL",
    "INFINITY",
    "NAN",
    "DBL_EPSILON",
    "DBL_MIN",
    "DBL_MAX",
    "EOF",
    "NULL",
    "FP_NAN",
    "FP_INFINITE",
    "FP_ZERO",
    "FP_NORMAL",
    "FP_SUBNORMAL",
    "MATH_ERRNO",
    "MATH_ERREXCEPT",
    "math_errhandling",
    "p",
    "s",
    "u",
    "x",
    "t",
    "at",
    "r",
    "b",
    "dx",
    "z",
];

/// A C identifier for a model name (letters, digits and `_`): itself, with a trailing `_`
/// when C or the generated code holds it already, and with a leading `m` when it starts with
/// `_` (C reserves those names).
pub(crate) fn ident(name: &str) -> String {
    let name = if name.starts_with('_') {
        format!("m{name}")
    } else {
        name.to_string()
    };
    if TAKEN.contains(&name.as_str()) {
        format!("{name}_")
    } else {
        name
    }
}

/// The prefix of every name a model's C code declares: its name with anything but letters,
/// digits and `_` as `_`, never starting with a digit or `_`.
pub(crate) fn prefix(model: &str) -> String {
    let mut out: String = model
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !out.starts_with(|c: char| c.is_ascii_alphabetic()) {
        out.insert(0, 'm');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_c_holds_get_an_underscore() {
        assert_eq!(ident("Re"), "Re");
        assert_eq!(ident("int"), "int_");
        assert_eq!(ident("NAN"), "NAN_");
        assert_eq!(ident("_Gain"), "m_Gain");
        assert_eq!(ident("s"), "s_");
        assert_eq!(prefix("backlash_bench"), "backlash_bench");
        assert_eq!(prefix("2-tank"), "m2_tank");
        assert_eq!(prefix("_x"), "m_x");
    }
}
