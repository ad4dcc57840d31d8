//! The reference bench's residual generator as a firmware builds it: a `#![no_std]` crate
//! that includes the code `bgc models/backlash_bench.bg --emit rust` writes and depends on
//! the `bondgraph` runtime without its `std` feature (the functions of `f64` that `core`
//! lacks then come from `libm`; windows are sized at start, so a global allocator is needed,
//! not an operating system).
//!
//! `examples/replay.rs` runs it on a CSV record on the host; the end-to-end suite checks that
//! its residuals are those of `bgc residuals` on the same record, and that the included code
//! is what bgc writes today.
#![no_std]

/// The bench's residual code, as `bgc models/backlash_bench.bg --emit rust` writes it.
#[allow(missing_docs, unreachable_pub, non_snake_case, clippy::all)]
pub mod backlash_bench {
    include!("backlash_bench.rs");
}

use backlash_bench::{Params, ResidualGenerator, RAW_ORDERS, RAW_SIGNALS, RESIDUAL_COUNT};

/// How many raw signals a sample holds, in the order of [`backlash_bench::RAW_SIGNALS`].
pub const RAW: usize = RAW_SIGNALS.len();

/// The bench's monitor fed sample by sample, as a firmware's control loop would: Savitzky–Golay
/// estimates over `window` samples, of the degree `bgc residuals` takes (3, or the highest
/// order read if higher), the model's parameters.
#[derive(Clone, Debug)]
pub struct Monitor {
    generator: ResidualGenerator,
}

impl Monitor {
    /// A monitor of samples `step` seconds apart, estimating over `window` samples.
    pub fn new(step: f64, window: usize) -> Result<Monitor, bondgraph::EstimatorError> {
        let degree = RAW_ORDERS.iter().copied().max().unwrap_or(0).max(3);
        let generator = ResidualGenerator::savitzky_golay(Params::default(), step, window, degree)?;
        Ok(Monitor { generator })
    }

    /// Takes the sample at `t`; once the window is full, the instant its estimates are for
    /// (`t` less the estimator's delay) and every residual there.
    pub fn push(&mut self, t: f64, raw: [f64; RAW]) -> Option<(f64, [f64; RESIDUAL_COUNT])> {
        let residuals = self.generator.push(t, raw)?;
        Some((t - self.generator.delay(), residuals))
    }
}
