//! The two causalities a model is oriented in.

/// Which causality storage elements should take.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Mode {
    /// Integral causality, detectors as outputs: for simulation.
    Integral,
    /// Derivative causality, detectors inverted: for diagnosis.
    Diagnosis,
}
