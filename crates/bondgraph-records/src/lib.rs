//! Recorded samples as loggers write them, read into the columns a model's residuals need:
//! Matlab MAT-files (level 5, up to `-v7`), LabVIEW TDMS and ASAM MDF 4, each told by its
//! first bytes. Each format's reader checks every length and offset against the file, so a
//! damaged or hostile file is refused with where it stops making sense, never a panic; each
//! error names the variable or channel (and the row, from 1) in the user's words.
//!
//! `bgc residuals` and `bgc identify` read records through [`columns`] (CSV and Parquet are
//! theirs), and so does the Python package for a path.

mod mat;
mod mdf;
mod number;
mod tdms;

/// A format of record this crate reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A Matlab MAT-file (level 5; a 7.3 file is recognised to be refused).
    Mat,
    /// A LabVIEW TDMS file.
    Tdms,
    /// An ASAM MDF file (version 4 is read; 3 is recognised to be refused).
    Mdf,
}

impl Format {
    /// The format of `bytes`, by their first bytes, if it is one of these.
    pub fn of(bytes: &[u8]) -> Option<Format> {
        if mat::is_mat(bytes) {
            Some(Format::Mat)
        } else if bytes.starts_with(tdms::MAGIC) {
            Some(Format::Tdms)
        } else if bytes.starts_with(mdf::MAGIC) {
            Some(Format::Mdf)
        } else {
            None
        }
    }

    /// Its name, as the errors give it.
    pub fn name(self) -> &'static str {
        match self {
            Format::Mat => "a MAT-file",
            Format::Tdms => "TDMS",
            Format::Mdf => "MDF",
        }
    }
}

/// The columns `names` of the record `bytes` in `format`, in that order, all of one length:
/// MAT variables, TDMS channels (`group/channel` where several groups hold one) or the
/// channels of one MDF channel group (`names[0]`, the time, its master channel unless a
/// channel has that name).
pub fn columns(format: Format, bytes: &[u8], names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    match format {
        Format::Mat => mat::columns(bytes, names),
        Format::Tdms => tdms::columns(bytes, names),
        Format::Mdf => mdf::columns(bytes, names),
    }
}
