//! Recorded samples read from CSV, Parquet, a Matlab `.mat` file, TDMS or MDF 4: a time
//! column with a uniform step and the columns a model's ARRs read.

use bondgraph_interpreter::{uniform_step, Step, StepError, JITTER_NOTED, STEP_TOLERANCE};

use std::path::Path;

use crate::io;
use crate::parquet_record;
use crate::report::{self, Failure};

/// Which columns of a record hold the time and the signals: the model's names, or others
/// (`--time`, `--column SIGNAL=NAME`).
pub(crate) struct Layout {
    /// The time column.
    pub(crate) time: String,
    /// The column of each signal, in the order asked for.
    pub(crate) signals: Vec<String>,
}

impl Layout {
    /// The columns of the signals `names` (the program's raw signals), named as in the model
    /// unless `columns` maps one (`SIGNAL=COLUMN`), and the time column `time`.
    pub(crate) fn new(names: &[String], time: &str, columns: &[String]) -> Result<Layout, Failure> {
        let mut signals = names.to_vec();
        for given in columns {
            let Some((signal, column)) = given.split_once('=') else {
                return Err(report::usage(format!(
                    "--column `{given}`: expected SIGNAL=COLUMN, e.g. y1=motor_speed"
                )));
            };
            let (signal, column) = (signal.trim(), column.trim());
            let Some(k) = names.iter().position(|n| n == signal) else {
                let near = bondgraph_core::closest(signal, names.iter().map(String::as_str));
                let hint = near.map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
                return Err(report::usage(format!(
                    "--column `{given}`: the ARRs read no `{signal}`{hint}; they read {}",
                    names.join(", ")
                )));
            };
            if column.is_empty() {
                return Err(report::usage(format!(
                    "--column `{given}`: the column's name is empty"
                )));
            }
            signals[k] = column.to_string();
        }
        Ok(Layout {
            time: time.to_string(),
            signals,
        })
    }
}

/// Recorded samples: the time and the columns asked for, checked.
pub(crate) struct Data {
    /// The time of each row.
    pub(crate) time: Vec<f64>,
    /// The step between rows (the median interval).
    pub(crate) step: f64,
    /// How far the time stamps stray from it, and where.
    pub(crate) clock: Step,
    /// Where that is, as the user finds it (a line of a CSV, a row of a table).
    clock_place: String,
    /// One column per name asked for, in that order.
    pub(crate) columns: Vec<Vec<f64>>,
}

impl Data {
    /// Reads the record at `path` as [`Data::read`] does, saying on standard error how far
    /// its time stamps jitter; a record that cannot be used is refused under its name.
    pub(crate) fn load(path: &Path, layout: &Layout, window: usize) -> Result<Data, Failure> {
        let name = path.display().to_string();
        let (_, bytes) = io::read(path)?;
        let data = Data::read(bytes, layout, window)
            .map_err(|e| report::refused(format!("{name}: {e}")))?;
        if let Some(note) = data.jitter_note() {
            report::note(format!("{name}: {note}"));
        }
        Ok(data)
    }

    /// Reads the record `bytes` (Parquet, a MAT-file, TDMS or MDF by their first bytes, or
    /// else CSV), keeping the columns of `layout`; needs at least `window` rows.
    pub(crate) fn read(bytes: Vec<u8>, layout: &Layout, window: usize) -> Result<Data, String> {
        let names: Vec<&str> = std::iter::once(layout.time.as_str())
            .chain(layout.signals.iter().map(String::as_str))
            .collect();
        // A table's rows are counted from 1; a CSV's by its lines, comments and all.
        let (mut columns, lines) = if bytes.starts_with(parquet_record::MAGIC) {
            (parquet_record::columns(bytes, &names)?, None)
        } else if let Some(format) = bondgraph_records::Format::of(&bytes) {
            (bondgraph_records::columns(format, &bytes, &names)?, None)
        } else {
            let (time, mut columns, lines) = read_csv(&bytes, &layout.time, &layout.signals)?;
            columns.insert(0, time);
            (columns, Some(lines))
        };
        let time = columns.remove(0);
        let place = |k: usize| match &lines {
            Some(lines) => format!("line {}", lines[k]),
            None => format!("row {}", k + 1),
        };
        let clock = check_time(&time, &place)?;
        let clock_place = place(clock.row);
        if time.len() < window {
            return Err(format!(
                "{} rows: the estimator's window of {window} samples needs at least {window}",
                time.len()
            ));
        }
        Ok(Data {
            time,
            step: clock.step,
            clock,
            clock_place,
            columns,
        })
    }

    /// The record without its first `rows` rows.
    pub(crate) fn skip(self, rows: usize) -> Data {
        Data {
            time: self.time[rows..].to_vec(),
            columns: self.columns.iter().map(|c| c[rows..].to_vec()).collect(),
            ..self
        }
    }

    /// What to tell the user of the record's time stamps, where they jitter: the step taken
    /// and how far the stamps stray from it.
    pub(crate) fn jitter_note(&self) -> Option<String> {
        (self.clock.jitter > JITTER_NOTED).then(|| {
            format!(
                "time stamps jitter: the step is their median interval, {} s; the farthest \
                 interval strays from it by {:.2e} of it ({}; up to {} is accepted)",
                io::seconds(self.step),
                self.clock.jitter,
                self.clock_place,
                STEP_TOLERANCE
            )
        })
    }
}

/// The time, the columns `names` and the line of each row of the CSV `bytes`.
type Read = (Vec<f64>, Vec<Vec<f64>>, Vec<u32>);

/// Reads CSV `bytes`, keeping the columns `time` and `names`.
fn read_csv(bytes: &[u8], time: &str, names: &[String]) -> Result<Read, String> {
    let delimiter = delimiter(bytes);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::Headers)
        .delimiter(delimiter)
        .from_reader(bytes);
    let header = reader
        .headers()
        .map_err(|e| format!("cannot read the header: {e}"))?
        .clone();
    let find = |name: &str| header.iter().position(|h| h == name);
    let missing = |name: &str, what: String| {
        let near = bondgraph_core::closest(name, header.iter().collect::<Vec<_>>().into_iter());
        let hint = near.map_or_else(String::new, |n| format!(" (did you mean `{n}`?)"));
        format!(
            "{what}{hint}; the header has {}",
            header.iter().collect::<Vec<_>>().join(", ")
        )
    };
    let t = find(time).ok_or_else(|| {
        // A one-letter name has no near miss by edits; a time column by another name does.
        let named = header
            .iter()
            .find(|h| h.to_lowercase().starts_with("time") || *h == "T");
        let what = format!("no time column: the header needs a column named `{time}`");
        match named {
            Some(h) => format!("{what} (is `{h}` the time? rename it or pass --time {h})"),
            None => missing(time, what),
        }
    })?;
    // A name twice in the header: which column is the record is a guess bgc does not make.
    for name in std::iter::once(time).chain(names.iter().map(String::as_str)) {
        let places: Vec<String> = (header.iter().enumerate())
            .filter(|(_, h)| *h == name)
            .map(|(k, _)| (k + 1).to_string())
            .collect();
        if places.len() > 1 {
            return Err(format!(
                "the header names `{name}` {} times (columns {}): keep one",
                places.len(),
                places.join(" and ")
            ));
        }
    }
    let mut at = vec![t];
    for name in names {
        at.push(find(name).ok_or_else(|| {
            missing(
                name,
                format!("no column `{name}`: the ARRs read {}", names.join(", ")),
            )
        })?);
    }
    let column_names: Vec<&str> = std::iter::once(time)
        .chain(names.iter().map(String::as_str))
        .collect();
    let start = usize::try_from(reader.position().byte()).unwrap_or(bytes.len());
    let body = bytes.get(start..).unwrap_or_default();
    let (mut columns, lines) = parse_rows(body, &at, &column_names, delimiter)?;
    let time = columns.remove(0);
    Ok((time, columns, lines))
}

/// The rows of `body` (the CSV after its header, which was line 1), the cells at `at` of each
/// as numbers, by column, and the line of the file each row is on (blank lines are skipped,
/// so a row's line is not its position). A large record is parsed in two halves at once, split at a line
/// end: parsing is a good part of `bgc residuals`' time, and a machine has two cores at
/// least. A record with quotes, where a line end may sit inside a cell, is parsed in one go.
fn parse_rows(
    body: &[u8],
    at: &[usize],
    names: &[&str],
    delimiter: u8,
) -> Result<(Vec<Vec<f64>>, Vec<u32>), String> {
    let split = (body.len() > 1 << 20 && !body.contains(&b'"'))
        .then(|| {
            let middle = body.len() / 2;
            body[middle..]
                .iter()
                .position(|&b| b == b'\n')
                .map(|k| middle + k + 1)
        })
        .flatten();
    let Some(split) = split else {
        return parse_part(body, at, names, 2, delimiter);
    };
    let (first, second) = body.split_at(split);
    let second_line = 2 + first.iter().filter(|&&b| b == b'\n').count();
    let (head, tail) = std::thread::scope(|scope| {
        let tail = scope.spawn(|| parse_part(second, at, names, second_line, delimiter));
        let head = parse_part(first, at, names, 2, delimiter);
        (head, tail.join())
    });
    // The first half's mistake comes first: it is on an earlier line.
    let (mut columns, mut lines) = head?;
    let (tail, tail_lines) =
        tail.map_err(|_| "the parser of the record's second half failed".to_string())??;
    for (column, rest) in columns.iter_mut().zip(tail) {
        column.extend(rest);
    }
    lines.extend(tail_lines);
    Ok((columns, lines))
}

/// The cell separator of a record: `,`, unless its header has none and is separated by `;`
/// (what a spreadsheet writes where the decimal mark is a comma) or by tabs.
fn delimiter(bytes: &[u8]) -> u8 {
    let header = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    let has = |c: u8| header.contains(&c);
    if has(b',') {
        b','
    } else if has(b';') {
        b';'
    } else if has(b'\t') {
        b'\t'
    } else {
        b','
    }
}

/// The rows of `part`, whose first line is `first` of the file, and the line of each.
fn parse_part(
    part: &[u8],
    at: &[usize],
    names: &[&str],
    first: usize,
    delimiter: u8,
) -> Result<(Vec<Vec<f64>>, Vec<u32>), String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .from_reader(part);
    let rows = part.iter().filter(|&&b| b == b'\n').count() + 1;
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows); at.len()];
    let mut lines: Vec<u32> = Vec::with_capacity(rows);
    // One record reused for every row: no allocation per row.
    let mut record = csv::ByteRecord::new();
    loop {
        // The line the reader stands on: the next record's, once blank lines are passed.
        let line_of = |position: Option<&csv::Position>, reader_line: u64| {
            first - 1
                + usize::try_from(position.map_or(reader_line, csv::Position::line)).unwrap_or(0)
        };
        match reader.read_byte_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let line = line_of(e.position(), reader.position().line());
                return Err(format!("line {line}: {e}"));
            }
        }
        let line = line_of(record.position(), reader.position().line());
        for ((column, &i), name) in columns.iter_mut().zip(at).zip(names) {
            let cell = record.get(i).unwrap_or(b"");
            let text = std::str::from_utf8(cell).unwrap_or("").trim();
            let value = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "line {line}, column `{name}`: `{}` is not a finite number",
                        String::from_utf8_lossy(cell).trim()
                    )
                })?;
            column.push(value);
        }
        lines.push(u32::try_from(line).unwrap_or(u32::MAX));
    }
    Ok((columns, lines))
}

/// The step of `time`, or the first row where it is not uniform (`place` names row `k` as
/// the user finds it: a line of a CSV, a row of a table).
fn check_time(time: &[f64], place: &dyn Fn(usize) -> String) -> Result<Step, String> {
    uniform_step(time).map_err(|e| match e {
        StepError::TooFew(n) => format!("{n} rows: too few samples"),
        StepError::NotIncreasing { row, from, to } => format!(
            "{}: time goes from {} to {}: it must increase",
            place(row),
            io::seconds(from),
            io::seconds(to)
        ),
        StepError::Uneven { row, found, step } => format!(
            "{}: a step of {} s where the record's (its median interval) is {} s, {:.1} % off \
             where {} % is accepted: the estimators need a uniform step (a dropped or doubled \
             sample, or a clock that jumped; resample the record to one step first)",
            place(row),
            io::seconds(found),
            io::seconds(step),
            100.0 * (found - step).abs() / step,
            100.0 * STEP_TOLERANCE
        ),
    })
}
