//! Runs a residual [`Program`](bondgraph_core::program::Program) on samples, as the
//! residual code bgc generates from the same program runs it: the same runtime estimators,
//! integrators and copy of the model, in the same order, so the two agree to rounding.
//! `bgc residuals` and the tests run models through it without compiling Rust.

mod calibrate;
mod calibration;
mod copy;
mod deviation;
mod fit;
mod fold;
mod generator;
mod hold;
mod identify;
mod linalg;
mod relations;
mod sensor;
mod size;
mod step;
mod walk;

pub use calibrate::{
    beyond, beyond_said, calibrate, window_of, Beyond, CalibrateError, Calibrated, Choices,
    Conditioning, CusumLevels, EstimatorKind, FalseAlarms, Range, Samples, Singular, GAIN,
    INTEGRATIONS, MODULATING_DEFAULT, REPLICAS, WINDOWS,
};
pub use calibration::{fnv1a, Calibration, Decision, Mismatch};
pub use fit::{Estimator, Fit, Integration};
pub use generator::{Estimates, Generator, BLOCK};
pub use hold::{Hold, Holding};
pub use identify::{
    choose_free, identify, identify_by, integration_window_for, simulate_record, simulation_error,
    Chosen, Combination, Criteria, Criterion, Determined, Estimate, Evidence, Identification,
    IdentifyError, Lost, Origin, Prefix, Reach, Record, Settings, Span, Stop, HELD_OUT,
};
pub use relations::Relations;
pub use size::{SizeOver, Sized, Sizing, DOUBLINGS, EXPLAINED, SIZE_SAMPLES, SIZE_WINDOW, TOLD};
pub use step::{uniform_step, Step, StepError, JITTER_NOTED, STEP_TOLERANCE};
pub use walk::Walk;
