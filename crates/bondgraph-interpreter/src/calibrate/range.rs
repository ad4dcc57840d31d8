//! What the healthy record covered: each signal's range. Thresholds hold for the plant
//! driven as calibration saw it; a record that visits amplitudes beyond (a larger input, a
//! faster speed) can cross them with no fault, and the user must be told which of its alarms
//! lie there. (The README's example, calibrated on a ±4 V sine and monitoring a 6 + 12 sin
//! record, alarmed from 8.18 s, 1.8 s before its fault, naming the link.)

use crate::calibrate::samples::Samples;

/// How far beyond the healthy range a value may lie and still count as seen: a share of
/// the range's width, so that noise and a slightly larger swing are not flagged.
const SLACK: f64 = 0.05;

/// One signal's range on the healthy record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The least value seen.
    pub least: f64,
    /// The largest value seen.
    pub most: f64,
}

impl Range {
    /// Whether `x` lies within the range, with its slack.
    pub fn holds(&self, x: f64) -> bool {
        let slack = SLACK * (self.most - self.least);
        (self.least - slack..=self.most + slack).contains(&x)
    }
}

/// Where a record first leaves what calibration saw of one signal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beyond {
    /// The signal, by its place in the program's raw signals.
    pub signal: usize,
    /// The first sample outside, by index.
    pub first: usize,
    /// The value farthest outside.
    pub farthest: f64,
    /// How many samples lie outside.
    pub samples: usize,
}

/// Each column's range over the whole record, start-up included (a plant at rest is a state
/// calibration saw); `None` for a column with no finite value.
pub(crate) fn ranges(healthy: &Samples<'_>) -> Vec<Option<Range>> {
    (healthy.columns.iter())
        .map(|column| {
            let seen = column.iter().filter(|x| x.is_finite());
            seen.fold(None, |r: Option<Range>, &x| {
                Some(r.map_or(Range { least: x, most: x }, |r| Range {
                    least: r.least.min(x),
                    most: r.most.max(x),
                }))
            })
        })
        .collect()
}

/// Where each column of `columns` leaves its range in `ranges` (the columns in the same
/// order), the earliest first; nothing for a column that stays within it.
pub fn beyond(ranges: &[Option<Range>], columns: &[&[f64]]) -> Vec<Beyond> {
    let mut out: Vec<Beyond> = (ranges.iter().zip(columns).enumerate())
        .filter_map(|(signal, (range, column))| {
            let range = (*range)?;
            let mut found: Option<Beyond> = None;
            for (k, &x) in column.iter().enumerate() {
                if !x.is_finite() || range.holds(x) {
                    continue;
                }
                let middle = 0.5 * (range.least + range.most);
                let b = found.get_or_insert(Beyond {
                    signal,
                    first: k,
                    farthest: x,
                    samples: 0,
                });
                b.samples += 1;
                if (x - middle).abs() > (b.farthest - middle).abs() {
                    b.farthest = x;
                }
            }
            found
        })
        .collect();
    out.sort_by_key(|b| b.first);
    out
}

/// The sentence that tells a user where a record leaves what calibration saw (`names`, the
/// signals' names; `time`, the record's), and whether its first alarm (`alarm`, seconds)
/// comes after that; `None` where it never does.
pub fn said(names: &[&str], found: &[Beyond], time: &[f64], alarm: Option<f64>) -> Option<String> {
    let first = found.first()?;
    let at = |k: usize| time.get(k).copied().unwrap_or(f64::NAN);
    let each: Vec<String> = (found.iter())
        .map(|b| {
            format!(
                "{} from {} s ({} samples; as far as {})",
                names.get(b.signal).copied().unwrap_or("?"),
                short(at(b.first)),
                b.samples,
                short(b.farthest)
            )
        })
        .collect();
    let alarm = match alarm {
        Some(t) if t >= at(first.first) => format!(
            "; the first alarm ({} s) comes after it left: it may be the record's, not a fault",
            short(t)
        ),
        Some(t) => format!("; the first alarm ({} s) comes before", short(t)),
        None => String::new(),
    };
    Some(format!(
        "the record goes beyond what the healthy record covered (each signal's range, and 5 % \
         of it): {}; the thresholds hold for the plant as calibration saw it driven{alarm}",
        each.join(", ")
    ))
}

/// `x` to four significant digits (at least to the unit).
fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_beyond_the_healthy_range_is_found_where_it_first_leaves_it() {
        let healthy: Vec<f64> = (0..100).map(|k| (k as f64 * 0.1).sin() * 4.0).collect();
        let time: Vec<f64> = (0..100).map(|k| k as f64).collect();
        let samples = Samples {
            time: &time,
            columns: vec![&healthy],
            step: 1.0,
        };
        let ranges = ranges(&samples);
        // Within the slack (5 % of the width) is seen; beyond it is not.
        let record = [0.0, 4.2, 3.0, -9.0, 18.0, 1.0];
        let found = beyond(&ranges, &[&record]);
        assert_eq!(
            found,
            [Beyond {
                signal: 0,
                first: 3,
                farthest: 18.0,
                samples: 2
            }]
        );
        assert!(beyond(&ranges, &[&healthy]).is_empty());
    }
}
