//! Recorded samples read from an ASAM MDF 4 file (automotive and test-bench loggers, CANape,
//! asammdf): the signals a channel group records together, each named as its column, the
//! group's master channel as the time unless a channel is named as the time column.
//!
//! An MDF 4 file is a tree of blocks, each `##XX`, its length, its links (file offsets) and
//! its data: the header links the data groups, each a list of channel groups (each a record
//! layout: its channels' data types, bit offsets and conversions) and a link to the records,
//! in one data block, a list of them, or zipped. Read by hand: no maintained crate reads it;
//! every offset and length is checked against the file, the blocks visited are bounded, and a
//! damaged file is refused with the block where it stops making sense.

use std::io::Read as _;

use crate::number::{little_endian, missing};

/// The first bytes of every MDF file (the format's file identifier).
pub(super) const MAGIC: &[u8] = b"MDF     ";

/// Most blocks visited: far past a logger's channels, short of what a loop of links would
/// fill memory with.
const MOST_BLOCKS: usize = 200_000;

/// The most bytes a zipped data block may inflate to.
const MOST_INFLATED: u64 = 1 << 31;

/// The columns `names` of the MDF file `bytes`, in that order; `names[0]` is the time: a
/// channel of that name, or else the master channel of the group the others are in. The
/// signals must be recorded in one channel group (one time base).
pub(super) fn columns(bytes: &[u8], names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    if bytes.len() < 64 {
        return Err("an MDF file starts with a 64-byte identification block".into());
    }
    let version = String::from_utf8_lossy(&bytes[8..16]).trim().to_string();
    if !version.starts_with('4') {
        return Err(format!(
            "an MDF {version} file is not read: only MDF 4 (save it as 4.10 or later)"
        ));
    }
    let mut file = File { bytes, visited: 0 };
    let groups = file.groups()?;
    let (time, signals) = names.split_first().ok_or("no column asked for")?;
    let holds = |g: &Group, n: &str| g.channels.iter().any(|c| c.name == n);
    let group = (groups.iter())
        .find(|g| signals.iter().all(|s| holds(g, s)))
        .ok_or_else(|| not_together(&groups, signals))?;
    let mut out = Vec::with_capacity(names.len());
    let master = if holds(group, time) {
        (group.channels.iter()).find(|c| c.name == *time)
    } else {
        (group.channels.iter()).find(|c| c.master)
    };
    let master = master.ok_or_else(|| {
        format!(
            "no channel `{time}` and no master channel in the group of {}",
            signals.join(", ")
        )
    })?;
    let records = file.records(group)?;
    out.push(master.values(&records, group.record_size)?);
    for s in signals {
        let channel = (group.channels.iter().filter(|c| !c.master))
            .chain(group.channels.iter().filter(|c| c.master))
            .find(|c| c.name == *s)
            .ok_or_else(|| format!("no channel `{s}`"))?;
        out.push(channel.values(&records, group.record_size)?);
    }
    Ok(out)
}

/// The error for signals no one channel group holds together.
fn not_together(groups: &[Group], signals: &[&str]) -> String {
    let everywhere: Vec<&str> = (groups.iter())
        .flat_map(|g| g.channels.iter().map(|c| c.name.as_str()))
        .collect();
    if let Some(absent) = signals.iter().find(|s| !everywhere.contains(s)) {
        let mut held = everywhere.clone();
        held.sort_unstable();
        return missing("channel", absent, held.into_iter());
    }
    format!(
        "{} are not recorded in one channel group: they have no one time base (resample them \
         onto one)",
        signals
            .iter()
            .map(|s| format!("`{s}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// A channel group: its record layout and where its records are.
struct Group {
    /// The data group's record-id size (0: the group is alone in its data group).
    id_size: usize,
    /// Its record id (with `id_size` > 0).
    record_id: u64,
    /// Bytes per record, without the record id.
    record_size: usize,
    /// How many records it has.
    cycles: u64,
    /// The data group's data link.
    data: u64,
    /// Every channel group of the same data group: (record id, record size), to step over
    /// their records.
    siblings: Vec<(u64, usize)>,
    channels: Vec<Channel>,
}

/// A channel of a record.
struct Channel {
    name: String,
    master: bool,
    /// A master with no bytes of its own: its value is the record's index, converted.
    virtual_master: bool,
    /// The format's data type (0–5: integers and floats, in either byte order).
    data_type: u8,
    bit_offset: u32,
    byte_offset: usize,
    bit_count: u32,
    /// `phys = a + b·raw`, from a linear or identity conversion; `Err` names a conversion
    /// this reader does not apply.
    conversion: Result<(f64, f64), String>,
}

impl Channel {
    /// Its physical values in the records `records` of `size` bytes each.
    fn values(&self, records: &[u8], size: usize) -> Result<Vec<f64>, String> {
        let (a, b) =
            (self.conversion.clone()).map_err(|why| format!("channel `{}`: {why}", self.name))?;
        if self.virtual_master {
            let rows = records.len() / size.max(1);
            return Ok((0..rows).map(|k| a + b * k as f64).collect());
        }
        let bits = self.bit_offset + self.bit_count;
        let width = bits.div_ceil(8) as usize;
        if self.data_type > 5 || width > 8 || self.bit_count == 0 || self.byte_offset + width > size
        {
            return Err(format!(
                "channel `{}` is not a number of at most 64 bits within its record (data type \
                 {}, {} bits at byte {}): strings, byte arrays and composed channels are not read",
                self.name, self.data_type, self.bit_count, self.byte_offset
            ));
        }
        let big = self.data_type % 2 == 1;
        let mut out = Vec::with_capacity(records.len() / size.max(1));
        for (row, record) in records.chunks_exact(size.max(1)).enumerate() {
            let raw = &record[self.byte_offset..self.byte_offset + width];
            let word = u64::from_le_bytes(little_endian(raw, big)) >> self.bit_offset;
            let masked = if self.bit_count >= 64 {
                word
            } else {
                word & ((1u64 << self.bit_count) - 1)
            };
            let raw = match (self.data_type, self.bit_count) {
                (0 | 1, _) => masked as f64,
                (2 | 3, n) if n < 64 => {
                    let shift = 64 - n;
                    (((masked << shift) as i64) >> shift) as f64
                }
                (2 | 3, _) => masked as i64 as f64,
                (_, 32) => f64::from(f32::from_bits(masked as u32)),
                (_, 64) => f64::from_bits(masked),
                (_, n) => {
                    return Err(format!(
                        "channel `{}` is a float of {n} bits: only 32 and 64 are read",
                        self.name
                    ))
                }
            };
            let v = a + b * raw;
            if !v.is_finite() {
                return Err(format!(
                    "channel `{}` has no finite number at row {} ({v})",
                    self.name,
                    row + 1
                ));
            }
            out.push(v);
        }
        Ok(out)
    }
}

/// The file's bytes, and how many blocks have been visited (bounded).
struct File<'b> {
    bytes: &'b [u8],
    visited: usize,
}

/// A block: its links and its data.
struct Block<'b> {
    links: Vec<u64>,
    data: &'b [u8],
}

impl<'b> File<'b> {
    /// The block at `at`, which must be a `##` + `id` one.
    fn block(&mut self, at: u64, id: &[u8; 2]) -> Result<Block<'b>, String> {
        self.visited += 1;
        if self.visited > MOST_BLOCKS {
            return Err(format!(
                "more than {MOST_BLOCKS} blocks: its links go round"
            ));
        }
        let start = usize::try_from(at)
            .ok()
            .filter(|&s| s + 24 <= self.bytes.len());
        let Some(start) = start else {
            return Err(format!(
                "a link points past the end of the file (byte {at})"
            ));
        };
        let head = &self.bytes[start..start + 24];
        if &head[..2] != b"##" || &head[2..4] != id {
            return Err(format!(
                "byte {at} should start a ##{} block and holds {:?}: the file is damaged",
                String::from_utf8_lossy(id),
                String::from_utf8_lossy(&head[..4])
            ));
        }
        let word = |k: usize| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&head[k..k + 8]);
            u64::from_le_bytes(w)
        };
        let (length, count) = (word(8), word(16));
        let end = usize::try_from(length)
            .ok()
            .and_then(|l| start.checked_add(l))
            .filter(|&e| e <= self.bytes.len());
        let links_end = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(8))
            .and_then(|l| start.checked_add(24 + l));
        let (Some(end), Some(links_end)) = (end, links_end.filter(|&l| Some(l) <= end)) else {
            return Err(format!(
                "the ##{} block at byte {at} runs past the end of the file",
                String::from_utf8_lossy(id)
            ));
        };
        let links = (self.bytes[start + 24..links_end].chunks_exact(8))
            .map(|c| {
                let mut w = [0u8; 8];
                w.copy_from_slice(c);
                u64::from_le_bytes(w)
            })
            .collect();
        Ok(Block {
            links,
            data: &self.bytes[links_end..end],
        })
    }

    /// The text of the `##TX` block at `at` ("" for no link).
    fn text(&mut self, at: u64) -> Result<String, String> {
        if at == 0 {
            return Ok(String::new());
        }
        let block = self.block(at, b"TX")?;
        let text = block.data.split(|&b| b == 0).next().unwrap_or(&[]);
        Ok(String::from_utf8_lossy(text).into_owned())
    }

    /// Every channel group of the file.
    fn groups(&mut self) -> Result<Vec<Group>, String> {
        let header = self.block(64, b"HD")?;
        let mut out = Vec::new();
        let mut dg = link(&header, 0);
        while dg != 0 {
            let block = self.block(dg, b"DG")?;
            let id_size = usize::from(*block.data.first().unwrap_or(&0));
            if ![0, 1, 2, 4, 8].contains(&id_size) {
                return Err(format!(
                    "the data group at byte {dg} has record ids of {id_size} bytes"
                ));
            }
            let (next, data) = (link(&block, 0), link(&block, 2));
            let mut cg = link(&block, 1);
            let first = out.len();
            while cg != 0 {
                let (group, next_cg) = self.group(cg, id_size, data)?;
                out.push(group);
                cg = next_cg;
            }
            let siblings: Vec<(u64, usize)> = out[first..]
                .iter()
                .map(|g| (g.record_id, g.record_size))
                .collect();
            for g in &mut out[first..] {
                g.siblings.clone_from(&siblings);
            }
            dg = next;
        }
        Ok(out)
    }

    /// The channel group at `at`, and the next one's link.
    fn group(&mut self, at: u64, id_size: usize, data: u64) -> Result<(Group, u64), String> {
        let block = self.block(at, b"CG")?;
        let d = block.data;
        if d.len() < 32 {
            return Err(format!("the channel group at byte {at} is too short"));
        }
        let u64_at = |k: usize| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&d[k..k + 8]);
            u64::from_le_bytes(w)
        };
        let u32_at = |k: usize| u32::from_le_bytes([d[k], d[k + 1], d[k + 2], d[k + 3]]);
        let flags = u16::from_le_bytes([d[16], d[17]]);
        if flags & 1 != 0 {
            return Err(format!(
                "the channel group at byte {at} holds variable-length signal data: not read"
            ));
        }
        let record_size = u32_at(24) as usize + u32_at(28) as usize;
        let mut channels = Vec::new();
        let mut cn = link(&block, 1);
        while cn != 0 {
            let (channel, next) = self.channel(cn)?;
            channels.push(channel);
            cn = next;
        }
        let group = Group {
            id_size,
            record_id: u64_at(0),
            record_size,
            cycles: u64_at(8),
            data,
            siblings: Vec::new(),
            channels,
        };
        Ok((group, link(&block, 0)))
    }

    /// The channel at `at`, and the next one's link.
    fn channel(&mut self, at: u64) -> Result<(Channel, u64), String> {
        let block = self.block(at, b"CN")?;
        let d = block.data;
        if d.len() < 16 {
            return Err(format!("the channel at byte {at} is too short"));
        }
        let u32_at = |k: usize| u32::from_le_bytes([d[k], d[k + 1], d[k + 2], d[k + 3]]);
        let name = self.text(link(&block, 2))?;
        let conversion = self.conversion(link(&block, 4))?;
        let channel = Channel {
            name,
            master: matches!(d[0], 2 | 3),
            virtual_master: d[0] == 3,
            data_type: d[2],
            bit_offset: u32::from(d[3]),
            byte_offset: u32_at(4) as usize,
            bit_count: u32_at(8),
            conversion,
        };
        Ok((channel, link(&block, 0)))
    }

    /// The conversion at `at` as `(a, b)` of `a + b·raw`, for none, the identity or a linear
    /// one; `Err` names any other.
    fn conversion(&mut self, at: u64) -> Result<Result<(f64, f64), String>, String> {
        if at == 0 {
            return Ok(Ok((0.0, 1.0)));
        }
        let block = self.block(at, b"CC")?;
        let d = block.data;
        if d.len() < 24 {
            return Err(format!("the conversion at byte {at} is too short"));
        }
        let value = |k: usize| {
            let s = 24 + 8 * k;
            d.get(s..s + 8).map(|b| {
                let mut w = [0u8; 8];
                w.copy_from_slice(b);
                f64::from_le_bytes(w)
            })
        };
        Ok(match d[0] {
            0 => Ok((0.0, 1.0)),
            1 => match (value(0), value(1)) {
                (Some(a), Some(b)) => Ok((a, b)),
                _ => return Err(format!("the linear conversion at byte {at} has no values")),
            },
            kind => Err(format!(
                "its conversion (type {kind}: rational, a formula, a table…) is not applied; \
                 export the physical values"
            )),
        })
    }

    /// The records of `group`, without their record ids, one after the other.
    fn records(&mut self, group: &Group) -> Result<Vec<u8>, String> {
        let mut raw = Vec::new();
        self.data(group.data, &mut raw)?;
        if group.id_size == 0 {
            let want = (group.cycles as usize).saturating_mul(group.record_size);
            raw.truncate(want.min(raw.len() - raw.len() % group.record_size.max(1)));
            return Ok(raw);
        }
        // Records of several groups, each after its id: keep this group's.
        let mut out = Vec::new();
        let mut at = 0usize;
        while at + group.id_size <= raw.len() {
            let mut w = [0u8; 8];
            w[..group.id_size].copy_from_slice(&raw[at..at + group.id_size]);
            let id = u64::from_le_bytes(w);
            at += group.id_size;
            let Some(&(_, size)) = group.siblings.iter().find(|(r, _)| *r == id) else {
                return Err(format!(
                    "a record at byte {at} of the data has the id {id}, which no channel group has"
                ));
            };
            let Some(record) = raw.get(at..at + size) else {
                break;
            };
            if id == group.record_id {
                out.extend_from_slice(record);
            }
            at += size;
        }
        Ok(out)
    }

    /// Appends the bytes of the data block (or list, or zipped block) at `at` to `out`.
    fn data(&mut self, at: u64, out: &mut Vec<u8>) -> Result<(), String> {
        if at == 0 {
            return Ok(());
        }
        match self.id(at) {
            b"HL" => {
                let block = self.block(at, b"HL")?;
                self.list(link(&block, 0), out)
            }
            b"DL" => self.list(at, out),
            _ => self.piece(at, out),
        }
    }

    /// The two letters of the block at `at` (none past the end).
    fn id(&self, at: u64) -> &'b [u8] {
        let bytes = self.bytes;
        (usize::try_from(at).ok())
            .and_then(|a| bytes.get(a.checked_add(2)?..a.checked_add(4)?))
            .unwrap_or(&[])
    }

    /// Appends the pieces of the data list at `at`, and of the lists after it.
    fn list(&mut self, mut at: u64, out: &mut Vec<u8>) -> Result<(), String> {
        while at != 0 {
            let block = self.block(at, b"DL")?;
            for &part in block.links.iter().skip(1) {
                self.piece(part, out)?;
            }
            at = link(&block, 0);
        }
        Ok(())
    }

    /// Appends one data block, plain or zipped (a list's piece; never a list itself).
    fn piece(&mut self, at: u64, out: &mut Vec<u8>) -> Result<(), String> {
        match self.id(at) {
            b"DT" => out.extend_from_slice(self.block(at, b"DT")?.data),
            b"DZ" => self.zipped(at, out)?,
            other => {
                return Err(format!(
                    "the data at byte {at} are a ##{} block, not DT or DZ",
                    String::from_utf8_lossy(other)
                ))
            }
        }
        Ok(())
    }

    /// A `##DZ` block's data, inflated (and transposed back where it was).
    fn zipped(&mut self, at: u64, out: &mut Vec<u8>) -> Result<(), String> {
        let block = self.block(at, b"DZ")?;
        let d = block.data;
        if d.len() < 24 {
            return Err(format!("the zipped block at byte {at} is too short"));
        }
        let (kind, columns) = (d[2], u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize);
        let mut w = [0u8; 8];
        w.copy_from_slice(&d[8..16]);
        let length = u64::from_le_bytes(w);
        if length > MOST_INFLATED {
            return Err(format!(
                "the zipped block at byte {at} inflates past {MOST_INFLATED} bytes"
            ));
        }
        let mut inflated = Vec::new();
        flate2::read::ZlibDecoder::new(&d[24..])
            .take(length)
            .read_to_end(&mut inflated)
            .map_err(|e| format!("the zipped block at byte {at} does not inflate: {e}"))?;
        match kind {
            0 => out.extend_from_slice(&inflated),
            1 if columns > 0 => {
                // Transposed as `rows × columns` bytes by column; a remainder was left as is.
                let rows = inflated.len() / columns;
                let body = rows * columns;
                let mut back = vec![0u8; body];
                for (k, &b) in inflated[..body].iter().enumerate() {
                    let (c, r) = (k / rows, k % rows);
                    back[r * columns + c] = b;
                }
                out.extend_from_slice(&back);
                out.extend_from_slice(&inflated[body..]);
            }
            other => {
                return Err(format!(
                    "the zipped block at byte {at} is zipped by method {other}"
                ))
            }
        }
        Ok(())
    }
}

/// The `k`-th link of `block`, 0 where it has none.
fn link(block: &Block<'_>, k: usize) -> u64 {
    block.links.get(k).copied().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block: `##id`, its length, its links, its data.
    fn block(id: &str, links: &[u64], data: &[u8]) -> Vec<u8> {
        let mut b = format!("##{id}").into_bytes();
        b.extend([0u8; 4]);
        b.extend(((24 + 8 * links.len() + data.len()) as u64).to_le_bytes());
        b.extend((links.len() as u64).to_le_bytes());
        for l in links {
            b.extend(l.to_le_bytes());
        }
        b.extend(data);
        b
    }

    /// A channel's data: type, sync, data type, bit offset, byte offset, bit count, the rest 0.
    fn channel(kind: u8, data_type: u8, byte: u32, bits: u32) -> Vec<u8> {
        let mut d = vec![kind, u8::from(kind == 2), data_type, 0];
        d.extend(byte.to_le_bytes());
        d.extend(bits.to_le_bytes());
        d.resize(72, 0);
        d
    }

    /// An MDF 4.10 file laid out as the format says: one data group, one channel group of
    /// records `time: f64, y: i16, pad`, `y` scaled by a linear conversion `0.5 + 2 x`.
    fn file(rows: &[(f64, i16)]) -> Vec<u8> {
        let mut out = b"MDF     4.10    test\0\0\0\0".to_vec();
        out.resize(64, 0);
        let at = |out: &Vec<u8>| out.len() as u64;
        // Laid out in order: HD, DG, CG, CN time, TX, CN y, TX, CC, DT.
        let hd = 64u64;
        let hd_len = 24 + 6 * 8 + 32;
        let dg = hd + hd_len;
        let dg_len = 24 + 4 * 8 + 8;
        let cg = dg + dg_len;
        let cg_len = 24 + 6 * 8 + 32;
        let cn_t = cg + cg_len;
        let cn_len = 24 + 8 * 8 + 72;
        let tx_t = cn_t + cn_len;
        let tx_len = 24 + 8;
        let cn_y = tx_t + tx_len;
        let tx_y = cn_y + cn_len;
        let cc = tx_y + tx_len;
        let cc_len = 24 + 4 * 8 + 24 + 16;
        let dt = cc + cc_len;
        out.extend(block("HD", &[dg, 0, 0, 0, 0, 0], &[0u8; 32]));
        out.extend(block("DG", &[0, cg, dt, 0], &[0u8; 8]));
        let mut g = 0u64.to_le_bytes().to_vec();
        g.extend((rows.len() as u64).to_le_bytes());
        g.extend([0u8; 8]);
        g.extend(16u32.to_le_bytes());
        g.extend(0u32.to_le_bytes());
        out.extend(block("CG", &[0, cn_t, 0, 0, 0, 0], &g));
        out.extend(block(
            "CN",
            &[cn_y, 0, tx_t, 0, 0, 0, 0, 0],
            &channel(2, 4, 0, 64),
        ));
        out.extend(block("TX", &[], b"time\0\0\0\0"));
        out.extend(block(
            "CN",
            &[0, 0, tx_y, 0, cc, 0, 0, 0],
            &channel(0, 2, 8, 16),
        ));
        out.extend(block("TX", &[], b"y\0\0\0\0\0\0\0"));
        let mut c = vec![1u8, 0, 0, 0, 0, 0, 2, 0];
        c.extend([0u8; 16]);
        c.extend(0.5f64.to_le_bytes());
        c.extend(2.0f64.to_le_bytes());
        out.extend(block("CC", &[0, 0, 0, 0], &c));
        assert_eq!(at(&out), dt, "the layout");
        let mut records = Vec::new();
        for &(t, y) in rows {
            records.extend(t.to_le_bytes());
            records.extend(y.to_le_bytes());
            records.extend([0u8; 6]);
        }
        out.extend(block("DT", &[], &records));
        out
    }

    #[test]
    fn the_master_is_the_time_and_conversions_are_applied() {
        let bytes = file(&[(0.0, 1), (0.5, -3), (1.0, 7)]);
        let got = columns(&bytes, &["t", "y"]).expect("read");
        assert_eq!(got, [vec![0.0, 0.5, 1.0], vec![2.5, -5.5, 14.5]]);
        let got = columns(&bytes, &["time", "y"]).expect("read");
        assert_eq!(got[0], [0.0, 0.5, 1.0]);
        let err = columns(&bytes, &["t", "w"]).expect_err("no w");
        assert!(
            err.contains("no channel `w`") && err.contains("`time`, `y`"),
            "{err}"
        );
    }

    /// Every prefix and every single flipped byte of a file is read or refused, never a
    /// panic, and never a hang (links that go round are bounded).
    #[test]
    fn damaged_files_are_refused_never_a_panic() {
        let good = file(&[(0.0, 1), (0.5, -3), (1.0, 7), (1.5, 2)]);
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
