//! Recorded samples read from a Matlab `.mat` file, level 5 (what `save` writes by default up
//! to `-v7`, and scipy's `savemat`): each signal a numeric vector named as the column it
//! stands for, with the same checks as a CSV record.
//!
//! Read by hand rather than through a crate: the format's numeric arrays are a few tagged
//! elements, and the crates that read it print to standard output from inside their parser
//! (which would corrupt a CSV written there) or unwrap on damaged data. A damaged or hostile
//! file is refused with where it stops making sense; nothing is allocated past the file's
//! own size, or past [`MOST_INFLATED`] for a compressed variable.

use std::io::Read as _;

use crate::number::{first_not_finite, missing, one_length, Number};

/// The start of a level-5 MAT-file's 116-byte text header.
pub(super) const MAGIC: &[u8] = b"MATLAB 5.0 MAT-file";

/// The start of a MATLAB 7.3 file's header: an HDF5 file, which this reader does not read.
const HDF5_MAGIC: &[u8] = b"MATLAB 7.3 MAT-file";

/// The most bytes one compressed variable may inflate to: 2 GiB, 268 million doubles, far
/// past a record's column and short of what a zip bomb would take.
const MOST_INFLATED: u64 = 1 << 31;

/// Whether `bytes` are a MAT-file of a level this reader knows of (5, or 7.3 to refuse).
pub(super) fn is_mat(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC) || bytes.starts_with(HDF5_MAGIC)
}

/// The variables `names` of the MAT-file `bytes`, in that order, each a real numeric vector
/// (n×1 or 1×n) of one length; a missing, complex, non-numeric or non-vector variable, or a
/// value that is not a finite number, is an error that names it (and the row, from 1).
pub(super) fn columns(bytes: &[u8], names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    if bytes.starts_with(HDF5_MAGIC) {
        return Err(
            "a MATLAB 7.3 file (HDF5) is not read: save it with `save(FILE, '-v7')`, \
                    or write it as CSV or Parquet"
                .into(),
        );
    }
    let variables = variables(bytes, names)?;
    let mut out = Vec::with_capacity(names.len());
    for &name in names {
        let Some(v) = variables.iter().find(|v| v.name == name) else {
            let held = variables.iter().map(|v| v.name.as_str());
            return Err(missing("variable", name, held));
        };
        out.push(v.column()?);
    }
    one_length("variables", names, out)
}

/// A variable of the file, its values decoded only once asked for.
struct Variable {
    name: String,
    /// Its dimensions, as stored.
    dims: Vec<usize>,
    /// What it holds.
    content: Content,
}

/// What a variable holds.
enum Content {
    /// Real numbers: the element type they are stored as, the byte order, their bytes.
    Real(Number, bool, Vec<u8>),
    /// Complex numbers.
    Complex,
    /// Something else: its class's name.
    Other(&'static str),
}

impl Variable {
    /// Its values as one column, checked.
    fn column(&self) -> Result<Vec<f64>, String> {
        let name = &self.name;
        let (stored, little, bytes) = match &self.content {
            Content::Real(stored, little, bytes) => (*stored, *little, bytes),
            Content::Complex => {
                return Err(format!(
                    "`{name}` holds complex numbers: a record's columns are real"
                ))
            }
            Content::Other(class) => {
                return Err(format!(
                    "`{name}` is a {class} array: a record's columns are numeric vectors"
                ))
            }
        };
        let many = self.dims.iter().filter(|&&d| d > 1).count();
        if many > 1 || self.dims.len() > 2 {
            let shape: Vec<String> = self.dims.iter().map(usize::to_string).collect();
            return Err(format!(
                "`{name}` is a {} array: a record's variables are vectors, one per signal",
                shape.join("×")
            ));
        }
        let count: usize = self.dims.iter().product();
        let values = stored.values(bytes, !little);
        if values.len() != count {
            return Err(format!(
                "`{name}` should hold {count} values and its data hold {}: the file is damaged",
                values.len()
            ));
        }
        if let Some((row, value)) = first_not_finite(&values) {
            return Err(format!(
                "`{name}` has no finite number at row {row} ({value})"
            ));
        }
        Ok(values)
    }
}

/// The number type of data type `code` (the format's `miINT8` … `miUINT64`): a MAT-file may
/// store a double array in a smaller integer type when its values fit.
fn stored(code: u32) -> Option<Number> {
    Some(match code {
        1 => Number::I8,
        2 => Number::U8,
        3 => Number::I16,
        4 => Number::U16,
        5 => Number::I32,
        6 => Number::U32,
        7 => Number::F32,
        9 => Number::F64,
        12 => Number::I64,
        13 => Number::U64,
        _ => return None,
    })
}

/// The format's data types that hold more than numbers.
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

/// A cursor over a MAT-file's bytes in its byte order; every read is checked against the
/// end, and says where it failed.
struct Cursor<'b> {
    bytes: &'b [u8],
    at: usize,
    little: bool,
    /// Where these bytes are, for messages: `byte N` of the file, or of a variable inflated.
    place: &'b str,
}

impl<'b> Cursor<'b> {
    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        let b = [b[0], b[1], b[2], b[3]];
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn take(&mut self, n: usize) -> Result<&'b [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(format!(
                "{} ends at byte {} inside an element of {n} bytes starting at byte {}: the file \
                 is cut short or damaged",
                self.place,
                self.bytes.len(),
                self.at
            ));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn done(&self) -> bool {
        self.at >= self.bytes.len()
    }

    /// The next element: its data type and its bytes, the padding to 8 bytes skipped (the
    /// small format packs up to 4 bytes into the tag).
    fn element(&mut self) -> Result<(u32, &'b [u8]), String> {
        let first = self.u32()?;
        if first >> 16 != 0 {
            let (kind, n) = (first & 0xffff, (first >> 16) as usize);
            let data = self.take(4)?;
            if n > 4 {
                return Err(format!(
                    "{}: a small element at byte {} says it holds {n} bytes, more than 4",
                    self.place,
                    self.at - 8
                ));
            }
            return Ok((kind, &data[..n]));
        }
        let n = self.u32()? as usize;
        let data = self.take(n)?;
        // Compressed elements are not padded.
        if first != MI_COMPRESSED {
            let pad = (8 - n % 8) % 8;
            let pad = pad.min(self.bytes.len() - self.at);
            self.at += pad;
        }
        Ok((first, data))
    }
}

/// Every variable of the level-5 MAT-file `bytes`, the values of those named in `asked` only
/// (a file may hold much that a record does not need).
fn variables(bytes: &[u8], asked: &[&str]) -> Result<Vec<Variable>, String> {
    if bytes.len() < 128 {
        return Err(format!(
            "a MAT-file starts with a 128-byte header; this one has {} bytes",
            bytes.len()
        ));
    }
    let little = match &bytes[126..128] {
        b"IM" => true,
        b"MI" => false,
        other => {
            return Err(format!(
                "its header's byte-order mark is {other:?}, not `IM` or `MI`: not a level-5 \
                 MAT-file"
            ))
        }
    };
    let mut file = Cursor {
        bytes: &bytes[128..],
        at: 0,
        little,
        place: "the file",
    };
    let mut out = Vec::new();
    while !file.done() {
        let start = file.at + 128;
        let (kind, data) = file.element()?;
        let variable = match kind {
            MI_MATRIX => matrix(data, little, "the file", asked)?,
            MI_COMPRESSED => {
                let inflated = inflate(data, start)?;
                let place = format!("the variable compressed at byte {start}");
                let mut inner = Cursor {
                    bytes: &inflated,
                    at: 0,
                    little,
                    place: &place,
                };
                match inner.element()? {
                    (MI_MATRIX, data) => matrix(data, little, &place, asked)?,
                    _ => continue,
                }
            }
            // Other top-level elements (a subsystem's data) hold no variable of a record.
            _ => continue,
        };
        out.push(variable);
    }
    Ok(out)
}

/// The zlib stream `data` of the compressed element at byte `start`, inflated.
fn inflate(data: &[u8], start: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut z = flate2::read::ZlibDecoder::new(data).take(MOST_INFLATED + 1);
    z.read_to_end(&mut out)
        .map_err(|e| format!("the variable compressed at byte {start} does not inflate: {e}"))?;
    if out.len() as u64 > MOST_INFLATED {
        return Err(format!(
            "the variable compressed at byte {start} inflates past {MOST_INFLATED} bytes"
        ));
    }
    Ok(out)
}

/// The array of a `miMATRIX` element's contents `data`: its flags, dimensions, name and
/// real (and imaginary) parts, kept if its name is `asked` for.
fn matrix(data: &[u8], little: bool, place: &str, asked: &[&str]) -> Result<Variable, String> {
    let mut c = Cursor {
        bytes: data,
        at: 0,
        little,
        place,
    };
    let (_, flags) = c.element()?;
    let word = |b: &[u8]| -> u32 {
        let b: [u8; 4] = [b[0], b[1], b[2], b[3]];
        if little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        }
    };
    if flags.len() < 8 {
        return Err(format!(
            "{place}: an array's flags hold {} bytes, not 8",
            flags.len()
        ));
    }
    let flags = word(&flags[..4]);
    let (class, complex) = (flags & 0xff, flags & 0x0800 != 0);
    let (_, dims) = c.element()?;
    let dims: Vec<usize> = (dims.chunks_exact(4))
        .map(|d| word(d) as i32)
        .map(|d| usize::try_from(d).unwrap_or(0))
        .collect();
    let (_, name) = c.element()?;
    let name = String::from_utf8_lossy(name).into_owned();
    let content = match class {
        _ if !asked.contains(&name.as_str()) => Content::Other("unread"),
        6..=15 if complex => Content::Complex,
        6..=15 => {
            let (kind, real) = c.element()?;
            let stored = stored(kind).ok_or_else(|| {
                format!("{place}: `{name}`'s values are of data type {kind}, not a number's")
            })?;
            Content::Real(stored, little, real.to_vec())
        }
        1 => Content::Other("cell"),
        2 => Content::Other("struct"),
        3 => Content::Other("object"),
        4 => Content::Other("char"),
        5 => Content::Other("sparse"),
        _ => Content::Other("unknown"),
    };
    Ok(Variable {
        name,
        dims,
        content,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A level-5 file written as the format lays it out: little-endian, one uncompressed
    /// double column `t`, one `int16` column `y` stored in the small element format's
    /// neighbour (a plain one), and a compressed double column `z`.
    fn file() -> Vec<u8> {
        let mut out = Vec::new();
        let mut header = b"MATLAB 5.0 MAT-file, written by a test".to_vec();
        header.resize(116, b' ');
        out.extend(header);
        out.extend([0u8; 8]);
        out.extend(0x0100u16.to_le_bytes());
        out.extend(b"IM");
        let element = |kind: u32, data: &[u8]| {
            let mut e = kind.to_le_bytes().to_vec();
            e.extend((data.len() as u32).to_le_bytes());
            e.extend(data);
            while e.len() % 8 != 0 {
                e.push(0);
            }
            e
        };
        let matrix = |name: &str, class: u32, kind: u32, values: Vec<u8>, n: u32| {
            let mut m = element(6, &[class.to_le_bytes(), 0u32.to_le_bytes()].concat());
            m.extend(element(5, &[n.to_le_bytes(), 1u32.to_le_bytes()].concat()));
            m.extend(element(1, name.as_bytes()));
            m.extend(element(kind, &values));
            element(MI_MATRIX, &m)
        };
        let doubles = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        out.extend(matrix("t", 6, 9, doubles(&[0.0, 0.5, 1.0]), 3));
        let shorts: Vec<u8> = [-2i16, 7, 300]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        out.extend(matrix("y", 6, 3, shorts, 3));
        let z = matrix("z", 6, 9, doubles(&[1.5, f64::MIN_POSITIVE, -3.0]), 3);
        let mut zlib = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut zlib, &z).expect("compressed");
        let compressed = zlib.finish().expect("compressed");
        out.extend(MI_COMPRESSED.to_le_bytes());
        out.extend((compressed.len() as u32).to_le_bytes());
        out.extend(compressed);
        out
    }

    #[test]
    fn vectors_are_read_whatever_their_storage_and_compression() {
        let got = columns(&file(), &["t", "y", "z"]).expect("read");
        assert_eq!(got[0], [0.0, 0.5, 1.0]);
        assert_eq!(got[1], [-2.0, 7.0, 300.0]);
        assert_eq!(got[2], [1.5, f64::MIN_POSITIVE, -3.0]);
    }

    /// Every prefix and every single flipped byte of a file is read or refused, never a
    /// panic, and a missing variable is named with what the file holds.
    #[test]
    fn damaged_files_are_refused_never_a_panic() {
        let good = file();
        let err = columns(&good, &["t", "w"]).expect_err("no w");
        assert!(
            err.contains("no variable `w`") && err.contains("`t`, `y`, `z`"),
            "{err}"
        );
        for n in 0..good.len() {
            let _ = columns(&good[..n], &["t", "z"]);
        }
        for k in 0..good.len() {
            let mut bad = good.clone();
            bad[k] ^= 0xa5;
            let _ = columns(&bad, &["t", "y", "z"]);
        }
        let mut hdf5 = b"MATLAB 7.3 MAT-file".to_vec();
        hdf5.resize(512, 0);
        assert!(columns(&hdf5, &["t"]).expect_err("7.3").contains("-v7"));
    }
}
