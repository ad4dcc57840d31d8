//! A record's time step: the estimators assume samples at one uniform step, and every
//! reader of records (the CLI's CSV and Parquet, the Python package's arrays) holds it to
//! the same rule.

/// The relative deviation from a record's first step that still counts as the same step.
pub const STEP_TOLERANCE: f64 = 1e-6;

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
    /// A step of `found` where the first is `step`.
    Uneven {
        /// The later sample.
        row: usize,
        /// The step found there.
        found: f64,
        /// The record's first step.
        step: f64,
    },
}

/// The uniform step of `time`, or the first place where it is not one.
pub fn uniform_step(time: &[f64]) -> Result<f64, StepError> {
    let [t0, t1, ..] = time else {
        return Err(StepError::TooFew(time.len()));
    };
    let step = t1 - t0;
    for (k, pair) in time.windows(2).enumerate() {
        let d = pair[1] - pair[0];
        if d <= 0.0 || d.is_nan() {
            return Err(StepError::NotIncreasing {
                row: k + 1,
                from: pair[0],
                to: pair[1],
            });
        }
        if (d - step).abs() > STEP_TOLERANCE * step {
            return Err(StepError::Uneven {
                row: k + 1,
                found: d,
                step,
            });
        }
    }
    Ok(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_step_within_a_millionth_and_the_first_place_it_breaks() {
        assert_eq!(uniform_step(&[0.0, 0.5, 1.0, 1.5 + 1e-9]), Ok(0.5));
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
            uniform_step(&[0.0, 1.0, 2.5]),
            Err(StepError::Uneven {
                row: 2,
                found: 1.5,
                step: 1.0
            })
        );
    }
}
