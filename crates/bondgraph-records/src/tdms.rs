//! Recorded samples read from a LabVIEW TDMS file (what NI's loggers, DIAdem and npTDMS
//! write): each signal a channel named as its column, in any group, with the same checks as a
//! CSV record.
//!
//! A TDMS file is a run of segments, each a lead-in, the metadata of the objects it writes
//! (their paths, the index of their raw data, their properties) and the raw data, in chunks
//! of every object's values, one after the other or interleaved. A segment may carry over the
//! previous segment's list of objects and their indexes. Read by hand: no maintained crate
//! reads it without a C library; every length is checked against the file, so a damaged or
//! hostile file is refused with the byte where it stops making sense.

use std::collections::HashMap;

use crate::number::{first_not_finite, missing, one_length, Number};

/// The first bytes of every TDMS segment.
pub(super) const MAGIC: &[u8] = b"TDSm";

/// The lead-in's table-of-contents flags.
const TOC_META_DATA: u32 = 1 << 1;
const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
const TOC_RAW_DATA: u32 = 1 << 3;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX_RAW_DATA: u32 = 1 << 7;

/// A raw-data index that says "none", and one that says "as in the previous segment".
const NO_RAW_DATA: u32 = 0xFFFF_FFFF;
const SAME_AS_BEFORE: u32 = 0;

/// The columns `names` of the TDMS file `bytes`, in that order: each the channel of that
/// name (or `group/channel` where several groups hold one), all of one length; a missing,
/// ambiguous or non-numeric channel, or a value that is not a finite number, is an error that
/// names it (and the row, from 1).
pub(super) fn columns(bytes: &[u8], names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    let channels = read(bytes)?;
    let mut out = Vec::with_capacity(names.len());
    for &name in names {
        let found: Vec<&Channel> = channels.iter().filter(|c| c.answers(name)).collect();
        let channel = match found.as_slice() {
            [one] => *one,
            [] => {
                let held: Vec<String> = channels.iter().map(Channel::label).collect();
                return Err(missing("channel", name, held.iter().map(String::as_str)));
            }
            several => {
                let held: Vec<String> =
                    several.iter().map(|c| format!("`{}`", c.label())).collect();
                return Err(format!(
                    "several groups hold a channel `{name}` ({}): name one as `group/channel`",
                    held.join(", ")
                ));
            }
        };
        out.push(channel.column()?);
    }
    one_length("channels", names, out)
}

/// A channel and its values, in file order.
struct Channel {
    group: String,
    name: String,
    /// Its element type, once it has raw data.
    kind: Option<Number>,
    values: Vec<f64>,
    /// Why its values cannot be read, if they cannot (a string, DAQmx raw data…).
    unreadable: Option<String>,
}

impl Channel {
    fn label(&self) -> String {
        format!("{}/{}", self.group, self.name)
    }

    /// Whether `name` names it: its own name, or `group/name`.
    fn answers(&self, name: &str) -> bool {
        name == self.name || name == self.label()
    }

    fn column(&self) -> Result<Vec<f64>, String> {
        if let Some(why) = &self.unreadable {
            return Err(format!("channel `{}`: {why}", self.label()));
        }
        if let Some((row, value)) = first_not_finite(&self.values) {
            let label = self.label();
            return Err(format!(
                "channel `{label}` has no finite number at row {row} ({value})"
            ));
        }
        Ok(self.values.clone())
    }
}

/// The number type of TDMS type code `code`, or what it holds when it is not a number.
fn kind_of(code: u32) -> Result<Number, &'static str> {
    Ok(match code {
        1 => Number::I8,
        2 => Number::I16,
        3 => Number::I32,
        4 => Number::I64,
        5 => Number::U8,
        6 => Number::U16,
        7 => Number::U32,
        8 => Number::U64,
        9 | 0x19 => Number::F32,
        10 | 0x1A => Number::F64,
        0x20 => return Err("strings"),
        0x21 => return Err("booleans"),
        0x44 => return Err("time stamps"),
        0x08_000C | 0x10_000D => return Err("complex numbers"),
        0xFFFF_FFFF => return Err("DAQmx raw data (scaled by the driver)"),
        _ => return Err("values of an unknown type"),
    })
}

/// How many values of an object a chunk holds, and of what type.
#[derive(Clone, Copy)]
struct Index {
    kind: Result<Number, &'static str>,
    count: u64,
    /// Bytes per chunk (strings carry their own size).
    bytes: u64,
}

/// A checked reader over bytes in one byte order.
struct Cursor<'b> {
    bytes: &'b [u8],
    at: usize,
    big: bool,
}

impl<'b> Cursor<'b> {
    fn take(&mut self, n: u64) -> Result<&'b [u8], String> {
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| self.at.checked_add(n))
            .filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(format!(
                "it ends at byte {} inside {n} bytes from byte {}: the file is cut short or damaged",
                self.bytes.len(),
                self.at
            ));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        let b = [b[0], b[1], b[2], b[3]];
        Ok(if self.big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    fn u64(&mut self) -> Result<u64, String> {
        let b = self.take(8)?;
        let mut w = [0u8; 8];
        w.copy_from_slice(b);
        Ok(if self.big {
            u64::from_be_bytes(w)
        } else {
            u64::from_le_bytes(w)
        })
    }

    fn string(&mut self) -> Result<String, String> {
        let n = self.u32()?;
        Ok(String::from_utf8_lossy(self.take(u64::from(n))?).into_owned())
    }

    /// Skips a property's value of type `code`.
    fn skip_value(&mut self, code: u32) -> Result<(), String> {
        let n = match code {
            0x20 => {
                let n = self.u32()?;
                u64::from(n)
            }
            1 | 5 | 0x21 => 1,
            2 | 6 => 2,
            3 | 7 | 9 | 0x19 => 4,
            4 | 8 | 10 | 0x1A | 0x08_000C => 8,
            0x44 | 11 | 0x10_000D => 16,
            other => {
                return Err(format!(
                    "a property at byte {} has type {other:#x}, which TDMS does not define",
                    self.at
                ))
            }
        };
        self.take(n).map(|_| ())
    }
}

/// Every channel of the TDMS file `bytes` with its values, segment after segment.
fn read(bytes: &[u8]) -> Result<Vec<Channel>, String> {
    let mut channels: Vec<Channel> = Vec::new();
    let mut by_path: HashMap<String, usize> = HashMap::new();
    let mut indexes: HashMap<String, Index> = HashMap::new();
    // The objects whose data the segments write, in order.
    let mut list: Vec<String> = Vec::new();
    // Its members, for a logger's thousands of channels in every segment.
    let mut listed: std::collections::HashSet<String> = Default::default();
    let mut at = 0usize;
    while at < bytes.len() {
        let mut c = Cursor {
            bytes,
            at,
            big: false,
        };
        if c.take(4)? != MAGIC {
            return Err(format!(
                "no TDMS segment starts at byte {at}: the file is damaged"
            ));
        }
        let toc = c.u32()?;
        c.big = toc & TOC_BIG_ENDIAN != 0;
        let _version = c.u32()?;
        let next = c.u64()?;
        let raw_offset = c.u64()?;
        let lead_end = c.at;
        // A segment whose length is all ones was cut short as it was written: its data run
        // to the end of the file.
        let end = if next == u64::MAX {
            bytes.len()
        } else {
            usize::try_from(next)
                .ok()
                .and_then(|n| lead_end.checked_add(n))
                .filter(|&e| e <= bytes.len())
                .ok_or_else(|| {
                    format!("the segment at byte {at} says it runs past the end of the file")
                })?
        };
        let data_start = usize::try_from(raw_offset)
            .ok()
            .and_then(|n| lead_end.checked_add(n))
            .filter(|&d| d <= end)
            .ok_or_else(|| format!("the segment at byte {at} puts its data past its end"))?;
        if toc & TOC_NEW_OBJ_LIST != 0 {
            list.clear();
            listed.clear();
        }
        if toc & TOC_META_DATA != 0 {
            let mut meta = Cursor {
                bytes: &bytes[..data_start],
                at: lead_end,
                big: c.big,
            };
            let objects = meta.u32()?;
            for _ in 0..objects {
                let path = meta.string()?;
                let index = meta.u32()?;
                match index {
                    NO_RAW_DATA => {}
                    SAME_AS_BEFORE => {
                        if !indexes.contains_key(&path) {
                            return Err(format!(
                                "`{path}` reuses a raw-data index it never had (segment at byte {at})"
                            ));
                        }
                    }
                    0x6912_0000 | 0x6913_0000 => {
                        return Err(format!(
                            "`{path}` holds DAQmx raw data, scaled by the NI driver: export the \
                             scaled channel instead"
                        ))
                    }
                    _ => {
                        let code = meta.u32()?;
                        let _dimension = meta.u32()?;
                        let count = meta.u64()?;
                        let kind = kind_of(code);
                        let bytes = if code == 0x20 {
                            meta.u64()?
                        } else {
                            count.saturating_mul(kind.map_or(0, |k| k.size() as u64))
                        };
                        indexes.insert(path.clone(), Index { kind, count, bytes });
                    }
                }
                if index != NO_RAW_DATA && listed.insert(path.clone()) {
                    list.push(path.clone());
                }
                let properties = meta.u32()?;
                for _ in 0..properties {
                    let _name = meta.string()?;
                    let code = meta.u32()?;
                    meta.skip_value(code)?;
                }
                if let Some((group, name)) = channel_of(&path) {
                    by_path.entry(path.clone()).or_insert_with(|| {
                        channels.push(Channel {
                            group,
                            name,
                            kind: None,
                            values: Vec::new(),
                            unreadable: None,
                        });
                        channels.len() - 1
                    });
                }
            }
        }
        if toc & TOC_RAW_DATA != 0 && toc & TOC_DAQMX_RAW_DATA == 0 {
            let data = &bytes[data_start..end];
            let layout: Vec<(usize, Index)> = (list.iter())
                .filter_map(|p| Some((*by_path.get(p)?, *indexes.get(p)?)))
                .collect();
            let interleaved = toc & TOC_INTERLEAVED != 0;
            raw_data(data, &layout, interleaved, c.big, &mut channels)
                .map_err(|e| format!("the data of the segment at byte {at}: {e}"))?;
        }
        // `end` is past the lead-in: every segment moves on.
        at = end;
    }
    Ok(channels)
}

/// The group and channel of an object path `/'group'/'channel'`, `None` for the file's and a
/// group's own objects.
fn channel_of(path: &str) -> Option<(String, String)> {
    let mut parts = Vec::new();
    let mut rest = path;
    while let Some(r) = rest.strip_prefix("/'") {
        // A quote inside a name is written twice.
        let mut name = String::new();
        let mut chars = r.char_indices().peekable();
        let mut close = None;
        while let Some((k, ch)) = chars.next() {
            if ch == '\'' {
                if matches!(chars.peek(), Some((_, '\''))) {
                    name.push('\'');
                    chars.next();
                } else {
                    close = Some(k);
                    break;
                }
            } else {
                name.push(ch);
            }
        }
        let close = close?;
        parts.push(name);
        rest = &r[close + 1..];
    }
    match parts.as_slice() {
        [group, channel] if rest.is_empty() => Some((group.clone(), channel.clone())),
        _ => None,
    }
}

/// Appends to `channels` the values of one segment's raw data `data`: chunks of the objects
/// of `layout` (their channel and index), contiguous or interleaved.
fn raw_data(
    data: &[u8],
    layout: &[(usize, Index)],
    interleaved: bool,
    big: bool,
    channels: &mut [Channel],
) -> Result<(), String> {
    let chunk: u64 = layout
        .iter()
        .map(|(_, i)| i.bytes)
        .fold(0, u64::saturating_add);
    if chunk == 0 || data.is_empty() {
        return Ok(());
    }
    let chunks = data.len() as u64 / chunk;
    for &(ch, index) in layout {
        let channel = &mut channels[ch];
        match index.kind {
            Err(what) => {
                channel.unreadable = Some(format!("it holds {what}, not numbers"));
            }
            Ok(kind) => {
                if channel.kind.is_some_and(|k| k != kind) {
                    channel.unreadable =
                        Some("its values change type from one segment to the next".into());
                }
                channel.kind = Some(kind);
            }
        }
    }
    let mut c = Cursor {
        bytes: data,
        at: 0,
        big,
    };
    for _ in 0..chunks {
        if interleaved {
            let rows = layout.iter().map(|(_, i)| i.count).max().unwrap_or(0);
            for _ in 0..rows {
                for &(ch, index) in layout {
                    let kind = index.kind.map_err(|what| format!("interleaved {what}"))?;
                    let v = kind.value(c.take(kind.size() as u64)?, big);
                    channels[ch].values.push(v);
                }
            }
        } else {
            for &(ch, index) in layout {
                let values = c.take(index.bytes)?;
                if let Ok(kind) = index.kind {
                    let vs = values.chunks_exact(kind.size()).map(|b| kind.value(b, big));
                    channels[ch].values.extend(vs);
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A segment as the format lays it out, little-endian, new object list: `channels` of
    /// doubles under group `g`, contiguous unless `toc_extra` says interleaved.
    fn segment(channels: &[(&str, &[f64])], toc_extra: u32) -> Vec<u8> {
        let string = |s: &str| {
            let mut b = (s.len() as u32).to_le_bytes().to_vec();
            b.extend(s.as_bytes());
            b
        };
        let mut meta = (2 + channels.len() as u32).to_le_bytes().to_vec();
        meta.extend(string("/"));
        meta.extend(NO_RAW_DATA.to_le_bytes());
        meta.extend(1u32.to_le_bytes());
        meta.extend(string("name"));
        meta.extend(0x20u32.to_le_bytes());
        meta.extend(string("a test"));
        meta.extend(string("/'g'"));
        meta.extend(NO_RAW_DATA.to_le_bytes());
        meta.extend(0u32.to_le_bytes());
        let mut raw = Vec::new();
        for (name, values) in channels {
            meta.extend(string(&format!("/'g'/'{name}'")));
            meta.extend(20u32.to_le_bytes());
            meta.extend(10u32.to_le_bytes());
            meta.extend(1u32.to_le_bytes());
            meta.extend((values.len() as u64).to_le_bytes());
            meta.extend(1u32.to_le_bytes());
            meta.extend(string("wf_increment"));
            meta.extend(10u32.to_le_bytes());
            meta.extend(0.001f64.to_le_bytes());
            if toc_extra & TOC_INTERLEAVED == 0 {
                raw.extend(values.iter().flat_map(|v| v.to_le_bytes()));
            }
        }
        if toc_extra & TOC_INTERLEAVED != 0 {
            for row in 0..channels[0].1.len() {
                raw.extend(channels.iter().flat_map(|(_, v)| v[row].to_le_bytes()));
            }
        }
        let toc = TOC_META_DATA | TOC_RAW_DATA | TOC_NEW_OBJ_LIST | toc_extra;
        let mut out = MAGIC.to_vec();
        out.extend(toc.to_le_bytes());
        out.extend(4713u32.to_le_bytes());
        out.extend(((meta.len() + raw.len()) as u64).to_le_bytes());
        out.extend((meta.len() as u64).to_le_bytes());
        out.extend(meta);
        out.extend(raw);
        out
    }

    #[test]
    fn channels_are_read_across_segments() {
        let mut file = segment(&[("t", &[0.0, 0.5]), ("y", &[1.0, -2.0])], 0);
        file.extend(segment(&[("t", &[1.0]), ("y", &[3.5])], 0));
        let got = columns(&file, &["t", "g/y"]).expect("read");
        assert_eq!(got, [vec![0.0, 0.5, 1.0], vec![1.0, -2.0, 3.5]]);
        let err = columns(&file, &["t", "w"]).expect_err("no w");
        assert!(
            err.contains("no channel `w`") && err.contains("`g/t`, `g/y`"),
            "{err}"
        );
    }

    /// A logger writing every channel's sample in turn.
    #[test]
    fn interleaved_data_are_read_row_by_row() {
        let file = segment(
            &[("t", &[0.0, 0.5, 1.0]), ("y", &[1.0, -2.0, 4.0])],
            TOC_INTERLEAVED,
        );
        let got = columns(&file, &["t", "y"]).expect("read");
        assert_eq!(got, [vec![0.0, 0.5, 1.0], vec![1.0, -2.0, 4.0]]);
    }

    #[test]
    fn names_with_quotes_and_slashes_are_parsed() {
        assert_eq!(
            channel_of("/'Dr. T''s Events'/'a/b'"),
            Some(("Dr. T's Events".into(), "a/b".into()))
        );
        assert_eq!(channel_of("/'group'"), None);
        assert_eq!(channel_of("/"), None);
    }

    /// Every prefix and every single flipped byte of a file is read or refused, never a
    /// panic.
    #[test]
    fn damaged_files_are_refused_never_a_panic() {
        let mut good = segment(&[("t", &[0.0, 0.5, 1.0]), ("y", &[1.0, -2.0, 4.0])], 0);
        good.extend(segment(&[("t", &[1.5]), ("y", &[3.5])], 0));
        for n in 0..good.len() {
            let _ = columns(&good[..n], &["t", "y"]);
        }
        for k in 0..good.len() {
            for flip in [0x01, 0x80, 0xff] {
                let mut bad = good.clone();
                bad[k] ^= flip;
                let _ = columns(&bad, &["t", "y"]);
            }
        }
    }
}
