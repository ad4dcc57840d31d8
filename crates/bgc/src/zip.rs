//! A zip archive written whole: deflated entries in a fixed order with a fixed date, so that
//! the same files give the same bytes (an FMU is one).

use std::io::Write as _;

/// The date every entry carries: 1980-01-01, 00:00, the first a zip can say.
const DOS_DATE: u16 = (1 << 5) | 1;
const DOS_TIME: u16 = 0;

/// Why an archive was not written.
#[derive(Debug)]
pub(crate) enum ZipError {
    /// An entry or the archive passes the 4 GiB a zip without its 64-bit extension holds.
    TooLarge(String),
    /// Deflating failed.
    Deflate(std::io::Error),
}

impl std::fmt::Display for ZipError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ZipError::TooLarge(name) => write!(f, "{name} passes the 4 GiB a zip holds"),
            ZipError::Deflate(e) => write!(f, "deflating failed: {e}"),
        }
    }
}

/// One entry, as the central directory lists it.
struct Entry {
    name: String,
    crc: u32,
    compressed: u32,
    size: u32,
    offset: u32,
}

/// The archive of `files` (name, bytes), in that order.
pub(crate) fn archive(files: &[(String, Vec<u8>)]) -> Result<Vec<u8>, ZipError> {
    let mut out = Vec::new();
    let mut entries = Vec::with_capacity(files.len());
    for (name, bytes) in files {
        let too_large = || ZipError::TooLarge(name.clone());
        let mut encoder =
            flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
        encoder.write_all(bytes).map_err(ZipError::Deflate)?;
        let data = encoder.finish().map_err(ZipError::Deflate)?;
        let entry = Entry {
            name: name.clone(),
            crc: crc32fast::hash(bytes),
            compressed: u32::try_from(data.len()).map_err(|_| too_large())?,
            size: u32::try_from(bytes.len()).map_err(|_| too_large())?,
            offset: u32::try_from(out.len()).map_err(|_| too_large())?,
        };
        out.extend(0x0403_4b50u32.to_le_bytes());
        header(&mut out, &entry);
        out.extend(0u16.to_le_bytes()); // no extra field
        out.extend(entry.name.as_bytes());
        out.extend(&data);
        entries.push(entry);
    }
    let directory =
        u32::try_from(out.len()).map_err(|_| ZipError::TooLarge("the archive".into()))?;
    for entry in &entries {
        out.extend(0x0201_4b50u32.to_le_bytes());
        out.extend(20u16.to_le_bytes()); // made by: zip 2.0
        header(&mut out, entry);
        out.extend(0u16.to_le_bytes()); // no extra field
        out.extend(0u16.to_le_bytes()); // no comment
        out.extend(0u16.to_le_bytes()); // disk 0
        out.extend(0u16.to_le_bytes()); // internal attributes
        out.extend(0u32.to_le_bytes()); // external attributes
        out.extend(entry.offset.to_le_bytes());
        out.extend(entry.name.as_bytes());
    }
    let size =
        u32::try_from(out.len()).map_err(|_| ZipError::TooLarge("the archive".into()))? - directory;
    let count =
        u16::try_from(entries.len()).map_err(|_| ZipError::TooLarge("the archive".into()))?;
    out.extend(0x0605_4b50u32.to_le_bytes());
    out.extend(0u16.to_le_bytes());
    out.extend(0u16.to_le_bytes());
    out.extend(count.to_le_bytes());
    out.extend(count.to_le_bytes());
    out.extend(size.to_le_bytes());
    out.extend(directory.to_le_bytes());
    out.extend(0u16.to_le_bytes());
    Ok(out)
}

/// The fields a local header and a central one share, from "version needed" to the name's
/// length.
fn header(out: &mut Vec<u8>, entry: &Entry) {
    out.extend(20u16.to_le_bytes()); // needs zip 2.0 (deflate)
    out.extend(0u16.to_le_bytes()); // no flags
    out.extend(8u16.to_le_bytes()); // deflated
    out.extend(DOS_TIME.to_le_bytes());
    out.extend(DOS_DATE.to_le_bytes());
    out.extend(entry.crc.to_le_bytes());
    out.extend(entry.compressed.to_le_bytes());
    out.extend(entry.size.to_le_bytes());
    // Names are the FMU's own, short and ASCII.
    out.extend((entry.name.len() as u16).to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The archive is what a zip reader reads back (Python's zipfile, where it is here), and
    /// the same files give the same bytes.
    #[test]
    fn an_archive_reads_back_and_is_the_same_every_time() {
        let files = vec![
            ("a.txt".to_string(), b"hello hello hello".to_vec()),
            ("dir/b.bin".to_string(), (0..=255u8).collect()),
            ("empty".to_string(), Vec::new()),
        ];
        let zip = archive(&files).expect("written");
        assert_eq!(zip, archive(&files).expect("written"));
        assert_eq!(&zip[..4], b"PK\x03\x04");
        assert_eq!(&zip[zip.len() - 22..zip.len() - 18], b"PK\x05\x06");
        let dir = std::env::temp_dir().join(format!("bgc-zip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("t.zip");
        std::fs::write(&path, &zip).expect("written");
        let script = "import sys, zipfile\nz = zipfile.ZipFile(sys.argv[1])\nassert z.testzip() is None\nfor i in z.infolist(): print(i.filename, len(z.read(i)), z.read(i)[:5])";
        if let Ok(out) = std::process::Command::new("python3")
            .args(["-c", script])
            .arg(&path)
            .output()
        {
            let text = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            assert_eq!(
                text,
                "a.txt 17 b'hello'\ndir/b.bin 256 b'\\x00\\x01\\x02\\x03\\x04'\nempty 0 b''\n"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
