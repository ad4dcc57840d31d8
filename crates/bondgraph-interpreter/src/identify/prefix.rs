//! What came before a record that a fit starts from: the generator's state after the
//! samples before it, so that a span late in a long record is fitted without running all
//! that came before it at every evaluation.

use crate::generator::Generator;
use crate::sensor::Noise;

use super::noise::{level, Normal, PROBE_ROWS};

/// Where the noise a prefix's noisy run adds comes from.
const SEED: u64 = 0x7072_6566_6978_2121;

/// The generator's state after the samples before a record, run on them as they are and
/// with white noise of each signal's level added: the probes that weigh each residual by
/// the noise it carries start from the noisy one, since a residual integrated from the
/// record's start carries the noise of every sample since (without it, such a residual
/// would be weighed as if it had none and drown the others).
#[derive(Clone)]
pub struct Prefix {
    pub(super) clean: Generator,
    pub(super) noisy: Generator,
    levels: Vec<Noise>,
    normal: Normal,
}

impl Prefix {
    /// The state of a fresh `generator` at the start of a record whose raw signals are
    /// `raw` (each one's noise level read on its first [`PROBE_ROWS`] samples, as a probe
    /// reads it: read on all of a 10^6-row record, the levels cost a third of the pass).
    pub fn new(generator: Generator, raw: &[&[f64]]) -> Prefix {
        Prefix {
            noisy: generator.clone(),
            clean: generator,
            levels: (raw.iter())
                .map(|c| level(&c[..c.len().min(PROBE_ROWS)]))
                .collect(),
            normal: Normal::new(SEED),
        }
    }

    /// Both runs taken on over the samples at `time` (raw column `k` of `raw` giving raw
    /// signal `k`).
    pub fn advance(&mut self, time: &[f64], raw: &[&[f64]]) {
        self.clean.run(time, raw, false, |_| {});
        // A quantiser's draw starts afresh at each call: the first sample's error is still
        // one a quantiser makes, only not correlated with the last call's.
        let noisy: Vec<Vec<f64>> = (raw.iter().zip(&self.levels))
            .map(|(column, noise)| {
                let e = noise.draw(column.len(), &mut self.normal);
                column.iter().zip(e).map(|(x, e)| x + e).collect()
            })
            .collect();
        let noisy: Vec<&[f64]> = noisy.iter().map(Vec::as_slice).collect();
        self.noisy.run(time, &noisy, false, |_| {});
    }
}
