//! Why a calibration could not be made.

use bondgraph::EstimatorError;

/// Why a calibration could not be made.
#[derive(Clone, Debug, PartialEq)]
pub enum CalibrateError {
    /// An estimator could not be built for the record's step.
    Estimator(String),
    /// The margin is not a number in [0, 1e6].
    Margin(f64),
    /// The crossing probability or the share is not a probability below 1.
    Probability(f64),
    /// The time within which a fault should show is not a positive number of seconds.
    Within(f64),
}

impl std::fmt::Display for CalibrateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CalibrateError::Estimator(e) => f.write_str(e),
            CalibrateError::Margin(m) if m.abs() >= 1e15 => {
                write!(f, "margin {m:e}: expected a number from 0 to 1e6")
            }
            CalibrateError::Margin(m) => write!(f, "margin {m}: expected a number from 0 to 1e6"),
            CalibrateError::Probability(p) => write!(f, "{p}: expected a probability in [0, 1)"),
            CalibrateError::Within(w) => {
                write!(f, "within {w} s: expected a positive number of seconds")
            }
        }
    }
}

impl std::error::Error for CalibrateError {}

impl From<EstimatorError> for CalibrateError {
    fn from(e: EstimatorError) -> Self {
        CalibrateError::Estimator(e.to_string())
    }
}
