//! What the formats share: numbers stored as integers or floats of 1 to 8 bytes in either byte
//! order, and the errors about the columns asked for.

/// A stored number's type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Number {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Number {
    /// Its size in bytes.
    pub(crate) fn size(self) -> usize {
        match self {
            Number::I8 | Number::U8 => 1,
            Number::I16 | Number::U16 => 2,
            Number::I32 | Number::U32 | Number::F32 => 4,
            Number::I64 | Number::U64 | Number::F64 => 8,
        }
    }

    /// The value of the first [`Number::size`] bytes of `b` (which must hold them), stored
    /// big-endian or not.
    pub(crate) fn value(self, b: &[u8], big: bool) -> f64 {
        let w = little_endian(&b[..self.size()], big);
        match self {
            Number::I8 => f64::from(w[0] as i8),
            Number::U8 => f64::from(w[0]),
            Number::I16 => f64::from(i16::from_le_bytes([w[0], w[1]])),
            Number::U16 => f64::from(u16::from_le_bytes([w[0], w[1]])),
            Number::I32 => f64::from(i32::from_le_bytes([w[0], w[1], w[2], w[3]])),
            Number::U32 => f64::from(u32::from_le_bytes([w[0], w[1], w[2], w[3]])),
            Number::F32 => f64::from(f32::from_le_bytes([w[0], w[1], w[2], w[3]])),
            Number::I64 => i64::from_le_bytes(w) as f64,
            Number::U64 => u64::from_le_bytes(w) as f64,
            Number::F64 => f64::from_le_bytes(w),
        }
    }

    /// Every whole value of `bytes` (a remainder is ignored).
    pub(crate) fn values(self, bytes: &[u8], big: bool) -> Vec<f64> {
        (bytes.chunks_exact(self.size()))
            .map(|c| self.value(c, big))
            .collect()
    }
}

/// Up to 8 bytes `b`, stored big-endian or not, as the low bytes of a little-endian word.
pub(crate) fn little_endian(b: &[u8], big: bool) -> [u8; 8] {
    let mut w = [0u8; 8];
    if big {
        for (k, x) in b.iter().rev().take(8).enumerate() {
            w[k] = *x;
        }
    } else {
        let n = b.len().min(8);
        w[..n].copy_from_slice(&b[..n]);
    }
    w
}

/// The error for a column `name` the file does not have, as a `what` ("variable",
/// "channel"), with the nearest name it does have and every name it has.
pub(crate) fn missing<'a>(what: &str, name: &str, held: impl Iterator<Item = &'a str>) -> String {
    let mut held: Vec<&str> = held.collect();
    let near = bondgraph_core::closest(name, held.iter().copied());
    let hint = near.map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
    held.dedup();
    let list = if held.is_empty() {
        "none".to_string()
    } else {
        let quoted: Vec<String> = held.iter().map(|h| format!("`{h}`")).collect();
        quoted.join(", ")
    };
    format!("no {what} `{name}`{hint}; it holds {list}")
}

/// `columns`, unless two of them (named by `names`) differ in length: a record's `what`s
/// ("variables", "channels") are its columns, of one length.
pub(crate) fn one_length(
    what: &str,
    names: &[&str],
    columns: Vec<Vec<f64>>,
) -> Result<Vec<Vec<f64>>, String> {
    let lengths: Vec<usize> = columns.iter().map(Vec::len).collect();
    match lengths.iter().position(|&n| n != lengths[0]) {
        Some(k) => Err(format!(
            "`{}` has {} values and `{}` {}: a record's {what} are its columns, of one length",
            names[0], lengths[0], names[k], lengths[k]
        )),
        None => Ok(columns),
    }
}

/// The row (from 1) and value of the first value of `values` that is not a finite number.
pub(crate) fn first_not_finite(values: &[f64]) -> Option<(usize, f64)> {
    (values.iter().position(|v| !v.is_finite())).map(|k| (k + 1, values[k]))
}
