//! The copy of the model that simulated residuals run.

use bondgraph::Replay;
use bondgraph_core::program::{CopyRates, Fill, Leaf, Program};
use bondgraph_core::Tape;

use crate::fold::fold;

/// The copy of the model, stepped on the raw inputs as the generated code steps it.
#[derive(Clone)]
pub(crate) struct CopyRun {
    pub(crate) replay: Replay,
    rates: Tape<Leaf>,
    /// The raw index of each input the rates read.
    inputs: Vec<usize>,
    /// Each simulated slot and the copy's state it reads.
    pub(crate) read: Vec<(usize, usize)>,
    /// Reused between samples.
    u: Vec<f64>,
    scratch: Vec<f64>,
    out: Vec<f64>,
}

impl CopyRun {
    /// The copy `copy` of `program`, with the parameters `params`.
    pub(crate) fn new(program: &Program, copy: &CopyRates, params: &[f64]) -> CopyRun {
        let (pool, rates) = fold(&program.code, &copy.rates, params);
        let read = (program.slots.iter())
            .filter_map(|(h, s)| match s.fill {
                Fill::Simulated(k) => Some((h.index(), k.index())),
                _ => None,
            })
            .collect();
        CopyRun {
            replay: Replay::new(&vec![0.0; copy.rates.len()]),
            rates: Tape::new(&pool, &rates),
            inputs: copy.inputs.iter().map(|h| h.index()).collect(),
            read,
            u: vec![0.0; copy.inputs.len()],
            scratch: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Goes on with the rates of `other` (the same copy with other parameters), from the
    /// state it is in.
    pub(crate) fn take_rates(&mut self, other: CopyRun) {
        self.rates = other.rates;
    }

    /// Advances the copy to the raw samples at `t`.
    pub(crate) fn push(&mut self, t: f64, raw: &[f64]) {
        for (u, &k) in self.u.iter_mut().zip(&self.inputs) {
            *u = raw[k];
        }
        let CopyRun {
            replay,
            rates,
            u,
            scratch,
            out,
            ..
        } = self;
        replay.push(t, u, |t, x, u, dx| {
            let leaf = |l: Leaf| match l {
                Leaf::State(k) => x[k.index()],
                Leaf::Input(j) => u[j.index()],
                Leaf::Time => t,
                Leaf::Slot(_) | Leaf::Parameter(_) => f64::NAN,
            };
            rates.values_into(leaf, |_| f64::NAN, scratch, out);
            dx.copy_from_slice(out);
        });
    }
}
