//! A record's time step: the estimators assume samples at one uniform step, and every
//! reader of records (the CLI's CSV and Parquet, the Python package's arrays) holds it to
//! the same rule. A real acquisition's time stamps jitter: the step is the median of the
//! intervals, and intervals within [`STEP_TOLERANCE`] of it count as that step.

/// The relative deviation of an interval from a record's step (the median interval) that
/// still counts as that step. A stamp late by 1 % of the step moves a sample by 1 % of its
/// change over one step, far below an encoder's or a current sensor's noise at the rates
/// benches sample at; an interval further off is a dropped or doubled sample, or a clock
/// that jumped, which the estimators must not read as a uniform record.
pub const STEP_TOLERANCE: f64 = 1e-2;

/// The relative jitter below which a record is called uniform without a word: what
/// printing decimal times leaves.
pub const JITTER_NOTED: f64 = 1e-6;

/// A record's step, as [`uniform_step`] finds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// The median interval between samples.
    pub step: f64,
    /// The largest relative deviation of an interval from `step`.
    pub jitter: f64,
    /// The later sample of that interval (from 0).
    pub row: usize,
}

/// Why a record's times are not at a uniform step; `row` is the position of the later of
/// the two samples concerned (from 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepError {
    /// Fewer than two samples: no step at all.
    TooFew(usize),
    /// Time does not increase from `from` to `to`.
    NotIncreasing {
        /// The later sample.
        row: usize,
        /// The time before.
        from: f64,
        /// The time at `row`.
        to: f64,
    },
    /// An interval of `found` where the record's step (the median interval) is `step`:
    /// further from it than [`STEP_TOLERANCE`].
    Uneven {
        /// The later sample.
        row: usize,
        /// The step found there.
        found: f64,
        /// The record's step.
        step: f64,
    },
}

/// The step of `time` (the median interval) and its jitter, or the first place where an
/// interval is not that step within [`STEP_TOLERANCE`].
pub fn uniform_step(time: &[f64]) -> Result<Step, StepError> {
    if time.len() < 2 {
        return Err(StepError::TooFew(time.len()));
    }
    let mut intervals = Vec::with_capacity(time.len() - 1);
    for (k, pair) in time.windows(2).enumerate() {
        let d = pair[1] - pair[0];
        if d <= 0.0 || d.is_nan() {
            return Err(StepError::NotIncreasing {
                row: k + 1,
                from: pair[0],
                to: pair[1],
            });
        }
        intervals.push(d);
    }
    let middle = median(&mut intervals.clone());
    // Where the first interval is the median but for rounding (decimal times, `k·h` in
    // floating point), it is the step: a record and its first rows then share it to the
    // bit, and so do their estimates.
    let first = intervals[0];
    let step = if (first - middle).abs() <= 1e-9 * middle {
        first
    } else {
        middle
    };
    let mut found = Step {
        step,
        jitter: 0.0,
        row: 1,
    };
    for (k, d) in intervals.into_iter().enumerate() {
        let jitter = (d - step).abs() / step;
        if jitter > STEP_TOLERANCE {
            return Err(StepError::Uneven {
                row: k + 1,
                found: d,
                step,
            });
        }
        if jitter > found.jitter {
            found.jitter = jitter;
            found.row = k + 1;
        }
    }
    Ok(found)
}

/// The median of `values` (not empty, no NaN), the lower middle one of an even count:
/// always one of the intervals, so a record of two steps takes one of them, not their mean.
fn median(values: &mut [f64]) -> f64 {
    let middle = (values.len() - 1) / 2;
    *values.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_step_within_its_tolerance_and_the_first_place_it_breaks() {
        let step = uniform_step(&[0.0, 0.5, 1.0, 1.5 + 1e-9]).expect("uniform");
        assert_eq!(step.step, 0.5);
        assert!(step.jitter < 1e-8 && step.row == 3);
        assert_eq!(uniform_step(&[0.0]), Err(StepError::TooFew(1)));
        assert_eq!(
            uniform_step(&[0.0, 1.0, 1.0]),
            Err(StepError::NotIncreasing {
                row: 2,
                from: 1.0,
                to: 1.0
            })
        );
        assert_eq!(
            uniform_step(&[0.0, 1.0, 2.0, 3.5]),
            Err(StepError::Uneven {
                row: 3,
                found: 1.5,
                step: 1.0
            })
        );
    }

    #[test]
    fn jittered_stamps_take_the_median_interval_and_say_how_far_they_stray() {
        // Stamps off the 1 ms grid by up to 3e-8 s (3e-5 of the step, a logger's jitter).
        let time: Vec<f64> = (0..1000)
            .map(|k| 1e-3 * k as f64 + 3e-8 * ((k * 7919) % 13) as f64 / 12.0)
            .collect();
        let step = uniform_step(&time).expect("jitter within the tolerance");
        assert!((step.step - 1e-3).abs() < 3e-8, "{step:?}");
        assert!(step.jitter > 1e-5 && step.jitter < 7e-5, "{step:?}");
        let d = time[step.row] - time[step.row - 1];
        assert!(((d - step.step).abs() / step.step - step.jitter).abs() < 1e-12);
        // A dropped sample is an interval of twice the step: refused where it is.
        let mut dropped = time.clone();
        dropped.remove(500);
        assert!(matches!(
            uniform_step(&dropped),
            Err(StepError::Uneven { row: 500, .. })
        ));
    }
}
