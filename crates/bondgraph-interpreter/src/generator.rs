//! The residual generator of a program, run sample by sample.

use bondgraph::{Differentiator, EstimatorError, Reference, RootFinder, Trapezoid};
use bondgraph_core::program::{Code, Evaluation, Fill, Leaf, Program, Source};
use bondgraph_core::{Compiled, Tape};

use crate::copy::CopyRun;
use crate::fit::{Built, Fit};
use crate::fold::tape;

/// What one channel of the bank is fed from the raw samples.
#[derive(Clone)]
enum Feed {
    Raw(usize),
    Integral(usize, Trapezoid),
}

/// A slot filled at the estimates' instant from the slots before it.
#[derive(Clone)]
enum Step {
    /// By integrating an expression.
    Integral {
        slot: usize,
        integrand: Tape<Leaf>,
        rule: Trapezoid,
    },
    /// As the root of a law (its residual and slope, in one tape).
    Root {
        slot: usize,
        law: Tape<Leaf>,
        finder: RootFinder,
    },
}

/// The residual generator of a program, run at run time: the same estimators, in the same
/// order, as the generated `ResidualGenerator` of the same program. It takes samples a block
/// at a time and runs each stage over the whole block before the next (one tape step over
/// every estimate, one estimator over every sample), so that the interpreter's dispatch is
/// paid once per block rather than once per sample.
#[derive(Clone)]
pub struct Generator {
    /// One estimator per channel, and what it is fed.
    estimators: Vec<Built>,
    feeds: Vec<Feed>,
    /// For each channel, the slots of the derivatives read, by order.
    scatter: Vec<Vec<(usize, usize)>>,
    steps: Vec<Step>,
    residuals: Tape<Leaf>,
    /// How many residuals.
    count: usize,
    /// Every sensitivity `∂r/∂θ` of every residual, in order.
    sensitivities: Tape<Leaf>,
    /// For each of them, its residual and `Δθ`.
    weights: Vec<(usize, f64)>,
    /// Each residual realised by integration, with its reference.
    references: Vec<(usize, Reference)>,
    /// The copy of the model simulated residuals run, if any.
    copy: Option<CopyRun>,
    delay: f64,
    slots: usize,
    /// Reused between blocks, so that a block allocates nothing once they have grown.
    work: Work,
}

/// The buffers of one block.
#[derive(Clone, Default)]
struct Work {
    /// Each channel's input over the block, when it is not a raw column.
    fed: Vec<f64>,
    /// Each channel's estimates over the block, order by order.
    estimates: Vec<Vec<f64>>,
    /// The block's samples that give an estimate.
    rows: Vec<usize>,
    /// Each slot's values over the estimates, slot by slot.
    values: Vec<f64>,
    /// What [`Estimates`] reads: each estimate's instant and unsolved root, each
    /// residual's values and bounds over the estimates.
    at: Vec<f64>,
    unsolved: Vec<Option<usize>>,
    residuals: Vec<f64>,
    bounds: Vec<f64>,
    /// The tapes' working columns; an integrand's values, or the copy's states, over the
    /// estimates; one sample's raw values, or a law and its slope at one estimate.
    scratch: Vec<f64>,
    buffer: Vec<f64>,
    point: Vec<f64>,
}

/// The estimators' output over a whole record, channel by channel and order by order: what
/// no parameter changes (see [`Generator::estimated`]).
pub(crate) struct Estimated {
    rows: usize,
    /// The first sample at which every channel has an estimate.
    first: usize,
    columns: Vec<Vec<f64>>,
}

impl Estimated {
    /// Itself, where it is small enough to keep (at most 128 MiB: 10^6 rows of 16
    /// estimated columns); a longer record has its estimators run again instead.
    pub(crate) fn small_enough(self) -> Option<Estimated> {
        let bytes: usize = self.columns.iter().map(|c| c.len() * 8).sum();
        (bytes <= 128 << 20).then_some(self)
    }

    /// The estimators' output over the sum of this record and `sign` times `other` (of
    /// the same length and channels): every estimator is linear, so this is it, to
    /// rounding.
    pub(crate) fn plus(&self, other: &Estimated, sign: f64) -> Estimated {
        Estimated {
            rows: self.rows,
            first: self.first.max(other.first),
            columns: (self.columns.iter().zip(&other.columns))
                .map(|(a, b)| a.iter().zip(b).map(|(a, b)| a + sign * b).collect())
                .collect(),
        }
    }
}

/// The residuals of a block of samples, as [`Generator::push_block`] gives them: one
/// estimate per sample once the windows are full, each residual as a column.
pub struct Estimates<'g> {
    count: usize,
    at: &'g [f64],
    residuals: &'g [f64],
    bounds: &'g [f64],
    unsolved: &'g [Option<usize>],
}

impl<'g> Estimates<'g> {
    /// How many estimates.
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether there are none (the windows are not full yet).
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// How many residuals each estimate has.
    pub fn residual_count(&self) -> usize {
        self.count
    }

    /// The instant of each estimate: its sample's time minus the estimators' delay.
    pub fn at(&self) -> &'g [f64] {
        self.at
    }

    /// Residual `k` at each estimate.
    pub fn residual(&self, k: usize) -> &'g [f64] {
        &self.residuals[k * self.len()..][..self.len()]
    }

    /// Residual `k`'s bound from parameter uncertainty at each estimate (zeros when not
    /// asked for).
    pub fn bound(&self, k: usize) -> &'g [f64] {
        &self.bounds[k * self.len()..][..self.len()]
    }

    /// At each estimate, the slot of the first root not found there (the residuals that
    /// read it are not numbers), if any.
    pub fn unsolved(&self) -> &'g [Option<usize>] {
        self.unsolved
    }
}

impl Generator {
    /// The generator of `program` with the parameters `params` (in the model's order),
    /// estimating as `how` says; `c` is the model the program was lowered from (for the
    /// parameters' uncertainties).
    pub fn new(
        c: &Compiled,
        program: &Program,
        params: &[f64],
        how: &Fit,
    ) -> Result<Generator, EstimatorError> {
        let top = program.top_order();
        let fit = |order: u32| how.estimator.built(order, top, how.step);
        let mut estimators = Vec::with_capacity(program.channels.len());
        let mut feeds = Vec::with_capacity(program.channels.len());
        for channel in program.channels.values() {
            estimators.push(fit(channel.order)?);
            feeds.push(match channel.source {
                Source::Raw(h) => Feed::Raw(h.index()),
                Source::Integral(h) => Feed::Integral(h.index(), Trapezoid::new()),
            });
        }
        let mut scatter = vec![Vec::new(); program.channels.len()];
        let mut steps = Vec::new();
        for (h, slot) in program.slots.iter() {
            match slot.fill {
                Fill::Estimate { channel, order } => {
                    scatter[channel.index()].push((order as usize, h.index()));
                }
                Fill::Integral(integrand) => steps.push(Step::Integral {
                    slot: h.index(),
                    integrand: tape(&program.code, &[integrand], params),
                    rule: Trapezoid::new(),
                }),
                Fill::Root { residual, slope } => steps.push(Step::Root {
                    slot: h.index(),
                    law: tape(&program.code, &[residual, slope], params),
                    finder: RootFinder::new(),
                }),
                Fill::Simulated(_) => {}
            }
        }
        let residuals: Vec<Code> = program.residuals.iter().map(|r| r.code).collect();
        let sensitivities: Vec<Code> = program.sensitivities.iter().map(|s| s.code).collect();
        let weights = (program.sensitivities.iter())
            .map(|s| {
                (
                    s.residual,
                    c.parameters[s.parameter].uncertainty.unwrap_or(0.0),
                )
            })
            .collect();
        let references = (program.residuals.iter().enumerate())
            .filter(|(_, r)| r.evaluation == Evaluation::Integrated)
            .map(|(k, _)| {
                (
                    k,
                    how.integration
                        .get(k)
                        .copied()
                        .unwrap_or_default()
                        .reference(),
                )
            })
            .collect();
        let delay = estimators.iter().map(|e| e.delay()).fold(0.0, f64::max);
        // A channel no slot reads (a raw signal only its integral is read of) costs a fit per
        // sample for nothing. Every channel has the same window, so the others say when the
        // estimates start; with none read at all, they all stay to say it.
        if scatter.iter().any(|reads| !reads.is_empty()) {
            let read = (estimators.into_iter().zip(feeds).zip(scatter))
                .filter(|(_, reads)| !reads.is_empty());
            let channels: Vec<_>;
            (channels, scatter) = read.unzip();
            (estimators, feeds) = channels.into_iter().unzip();
        }
        Ok(Generator {
            estimators,
            feeds,
            scatter,
            steps,
            residuals: tape(&program.code, &residuals, params),
            count: residuals.len(),
            sensitivities: tape(&program.code, &sensitivities, params),
            weights,
            references,
            copy: (program.copy.as_ref()).map(|copy| CopyRun::new(program, copy, params)),
            delay,
            slots: program.slots.len(),
            work: Work::default(),
        })
    }

    /// This generator, with every stage in the state the samples it has taken left it in,
    /// going on with the parameters `params` from the next sample (what a fault that begins
    /// there does): the estimators' windows, the integrals, the references and the copy of
    /// the model are kept; the laws read `params`. `c`, `program` and `how` are those it was
    /// made with.
    pub fn with_parameters(
        &self,
        c: &Compiled,
        program: &Program,
        params: &[f64],
        how: &Fit,
    ) -> Result<Generator, EstimatorError> {
        let fresh = Generator::new(c, program, params, how)?;
        let mut g = self.clone();
        for (step, new) in g.steps.iter_mut().zip(fresh.steps) {
            match (step, new) {
                (Step::Integral { integrand, .. }, Step::Integral { integrand: new, .. }) => {
                    *integrand = new;
                }
                (Step::Root { law, .. }, Step::Root { law: new, .. }) => *law = new,
                // The same program gives the same steps in the same order.
                _ => unreachable!("a step of another program"),
            }
        }
        g.residuals = fresh.residuals;
        g.sensitivities = fresh.sensitivities;
        if let (Some(copy), Some(new)) = (&mut g.copy, fresh.copy) {
            copy.take_rates(new);
        }
        Ok(g)
    }

    /// How far the estimates' instants lag the newest sample, in seconds.
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// The same generator with its copy of the model (if it runs one) taking `n` Runge–Kutta
    /// steps per sample interval instead of one (see `bondgraph::Replay::set_substeps`):
    /// what fitting and judging a simulation error needs where the copy moves fast against
    /// the samples. The generated code takes one.
    #[must_use]
    pub fn with_substeps(mut self, n: usize) -> Generator {
        if let Some(copy) = &mut self.copy {
            copy.replay.set_substeps(n);
        }
        self
    }

    /// Runs the samples at `time` (raw column `k` of `raw` giving raw signal `k`, in the
    /// program's raw order) through the generator, [`BLOCK`] samples at a time, and hands
    /// each block's estimates to `each`; `bounds` as in [`Generator::push_block`].
    pub fn run(
        &mut self,
        time: &[f64],
        raw: &[&[f64]],
        bounds: bool,
        mut each: impl FnMut(&Estimates<'_>),
    ) {
        let mut block: Vec<&[f64]> = Vec::with_capacity(raw.len());
        for start in (0..time.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(time.len());
            block.clear();
            block.extend(raw.iter().map(|column| &column[start..end]));
            each(&self.push_block(&time[start..end], &block, bounds));
        }
    }

    /// Takes the samples at `time` (raw column `k` of `raw` giving raw signal `k`, in the
    /// program's raw order; a shorter column is a caller's bug and panics) and returns the
    /// residuals of every sample once the windows are full, at the instants of the
    /// estimates, and with `bounds` each residual's bound from parameter uncertainty,
    /// `Σ |∂r/∂θ| Δθ` (else zeros). Blocks of any length give the same estimates, to the
    /// bit, as one block of all the samples: the stages keep their state between blocks.
    pub fn push_block(&mut self, time: &[f64], raw: &[&[f64]], bounds: bool) -> Estimates<'_> {
        let mut work = std::mem::take(&mut self.work);
        let first = self.estimate(time, raw, &mut work);
        self.after_estimates(time, raw, first, bounds, work)
    }

    /// Runs only the estimators over a whole record (as [`Generator::run`] would): their
    /// output, which no parameter changes. The generator must be fresh, and is spent.
    pub(crate) fn estimated(mut self, time: &[f64], raw: &[&[f64]]) -> Estimated {
        let mut work = Work::default();
        let first = self.estimate(time, raw, &mut work);
        Estimated {
            rows: time.len(),
            first,
            columns: work.estimates,
        }
    }

    /// [`Generator::run`] over the record `estimated` was made from (by [`Generator::estimated`]
    /// of a generator of the same program and fit, any parameters), taking the estimators'
    /// output from it instead of computing it again: the same estimates, to the bit, for the
    /// cost of the stages after the estimators. What a fit needs, which runs one record
    /// through generators of many parameter values. A record other than the one estimated
    /// is a caller's bug and panics.
    pub(crate) fn run_estimated(
        &mut self,
        time: &[f64],
        raw: &[&[f64]],
        estimated: &Estimated,
        bounds: bool,
        mut each: impl FnMut(&Estimates<'_>),
    ) {
        assert_eq!(estimated.rows, time.len(), "the record estimated");
        assert_eq!(
            estimated.columns.len(),
            self.estimators.len(),
            "the channels"
        );
        let mut block: Vec<&[f64]> = Vec::with_capacity(raw.len());
        for start in (0..time.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(time.len());
            block.clear();
            block.extend(raw.iter().map(|column| &column[start..end]));
            let mut work = std::mem::take(&mut self.work);
            work.estimates
                .resize_with(estimated.columns.len(), Vec::new);
            for (out, column) in work.estimates.iter_mut().zip(&estimated.columns) {
                out.clear();
                for order in column.chunks_exact(estimated.rows.max(1)) {
                    out.extend_from_slice(&order[start..end]);
                }
            }
            let first = estimated.first.saturating_sub(start).min(end - start);
            each(&self.after_estimates(&time[start..end], &block, first, bounds, work));
        }
    }

    /// The stages after the estimators, over a block whose estimates are in `work`, from
    /// its sample `first` on.
    fn after_estimates(
        &mut self,
        time: &[f64],
        raw: &[&[f64]],
        first: usize,
        bounds: bool,
        mut work: Work,
    ) -> Estimates<'_> {
        self.rows(time, raw, first, &mut work);
        let m = work.rows.len();
        self.scatter_estimates(time.len(), &mut work);
        work.unsolved.clear();
        work.unsolved.resize(m, None);
        self.steps(&mut work);
        self.residuals_of(bounds, &mut work);
        self.work = work;
        Estimates {
            count: self.count,
            at: &self.work.at,
            residuals: &self.work.residuals,
            bounds: &self.work.bounds,
            unsolved: &self.work.unsolved,
        }
    }

    /// Feeds every channel its samples and keeps the estimates; the first sample at which
    /// every channel has one.
    fn estimate(&mut self, time: &[f64], raw: &[&[f64]], work: &mut Work) -> usize {
        let n = time.len();
        work.estimates.resize_with(self.estimators.len(), Vec::new);
        let mut first = 0;
        let channels = self.estimators.iter_mut().zip(&mut self.feeds);
        for ((estimator, feed), out) in channels.zip(&mut work.estimates) {
            let xs: &[f64] = match feed {
                Feed::Raw(k) => &raw[*k][..n],
                Feed::Integral(k, rule) => {
                    work.fed.resize(n, 0.0);
                    rule.push_slice(time, &raw[*k][..n], &mut work.fed);
                    &work.fed
                }
            };
            out.resize((estimator.order() as usize + 1) * n, 0.0);
            first = first.max(estimator.push_slice(xs, out));
        }
        first
    }

    /// The samples from `first` on that give an estimate, and their instants: all of them
    /// but where the copy of the model has no state yet. The copy takes every sample.
    fn rows(&mut self, time: &[f64], raw: &[&[f64]], first: usize, work: &mut Work) {
        work.rows.clear();
        work.at.clear();
        let Some(copy) = &mut self.copy else {
            work.rows.extend(first..time.len());
            work.at.extend(time[first..].iter().map(|t| t - self.delay));
            return;
        };
        // The copy's states are read below, slot by slot, once the rows are known.
        work.buffer.clear();
        for (i, &t) in time.iter().enumerate() {
            work.point.clear();
            work.point.extend(raw.iter().map(|column| column[i]));
            copy.push(t, &work.point);
            if i < first {
                continue;
            }
            let at = t - self.delay;
            if let Some(x) = copy.replay.at(at) {
                work.rows.push(i);
                work.at.push(at);
                work.buffer.extend(copy.read.iter().map(|&(_, k)| x[k]));
            }
        }
    }

    /// Writes the estimates of the rows, and the copy's states, into their slots.
    fn scatter_estimates(&self, n: usize, work: &mut Work) {
        let m = work.rows.len();
        work.values.clear();
        work.values.resize(self.slots * m, 0.0);
        let contiguous = work.rows.first().is_some_and(|&r| r + m == n);
        for (reads, estimates) in self.scatter.iter().zip(&work.estimates) {
            for &(order, slot) in reads {
                let column = &estimates[order * n..][..n];
                let to = &mut work.values[slot * m..][..m];
                if contiguous {
                    to.copy_from_slice(&column[n - m..]);
                } else {
                    for (to, &i) in to.iter_mut().zip(&work.rows) {
                        *to = column[i];
                    }
                }
            }
        }
        if let Some(copy) = &self.copy {
            let width = copy.read.len();
            for (j, states) in work.buffer.chunks_exact(width.max(1)).enumerate().take(m) {
                for (&(slot, _), &x) in copy.read.iter().zip(states) {
                    work.values[slot * m + j] = x;
                }
            }
        }
    }

    /// Fills the slots set by integrating or by solving a law, in order, over the rows.
    fn steps(&mut self, work: &mut Work) {
        let m = work.rows.len();
        for step in &mut self.steps {
            match step {
                Step::Integral {
                    slot,
                    integrand,
                    rule,
                } => {
                    let (values, at) = (&work.values, &work.at);
                    integrand.columns_into(
                        m,
                        |l, to| leaf_column(l, to, values, at),
                        |_, to| to.fill(f64::NAN),
                        &mut work.scratch,
                        &mut work.buffer,
                    );
                    let to = &mut work.values[*slot * m..][..m];
                    rule.push_slice(&work.at, &work.buffer, to);
                }
                Step::Root { slot, law, finder } => {
                    for j in 0..m {
                        let at = work.at[j];
                        let root = finder.solve(|z| {
                            work.values[*slot * m + j] = z;
                            let values = &work.values;
                            let leaf = |l| leaf_at(l, j, m, values, at);
                            law.values_into(leaf, |_| f64::NAN, &mut work.scratch, &mut work.point);
                            (work.point[0], work.point[1])
                        });
                        work.values[*slot * m + j] = match root {
                            Some(z) => z,
                            // No root at this instant: what reads it is not a number, and the
                            // estimate says which slot was unsolved.
                            None => {
                                work.unsolved[j] = work.unsolved[j].or(Some(*slot));
                                f64::NAN
                            }
                        };
                    }
                }
            }
        }
    }

    /// The residuals over the rows, integrated ones taken from their references, and their
    /// bounds.
    fn residuals_of(&mut self, bounds: bool, work: &mut Work) {
        let m = work.rows.len();
        let (values, at) = (&work.values, &work.at);
        (self.residuals).columns_into(
            m,
            |l, to| leaf_column(l, to, values, at),
            |_, to| to.fill(f64::NAN),
            &mut work.scratch,
            &mut work.residuals,
        );
        for (k, reference) in &mut self.references {
            reference.push_slice(&mut work.residuals[*k * m..][..m]);
        }
        work.bounds.clear();
        work.bounds.resize(work.residuals.len(), 0.0);
        if bounds && !self.weights.is_empty() {
            (self.sensitivities).columns_into(
                m,
                |l, to| leaf_column(l, to, values, at),
                |_, to| to.fill(f64::NAN),
                &mut work.scratch,
                &mut work.buffer,
            );
            for (&(k, delta), s) in self.weights.iter().zip(work.buffer.chunks_exact(m.max(1))) {
                for (b, s) in work.bounds[k * m..][..m].iter_mut().zip(s) {
                    *b += s.abs() * delta;
                }
            }
        }
    }
}

/// How many samples [`Generator::run`] takes at a time: enough that each stage's dispatch
/// is paid over many samples, few enough that a block's values stay in the cache.
pub const BLOCK: usize = 256;

/// A leaf's values over the rows: a slot's, or the estimates' instants.
fn leaf_column(l: Leaf, to: &mut [f64], values: &[f64], at: &[f64]) {
    let m = to.len();
    match l {
        Leaf::Slot(h) => to.copy_from_slice(&values[h.index() * m..][..m]),
        Leaf::Time => to.copy_from_slice(at),
        // Folded, or read only by the copy's rates.
        Leaf::Parameter(_) | Leaf::State(_) | Leaf::Input(_) => to.fill(f64::NAN),
    }
}

/// A leaf's value at row `j` of `m`.
fn leaf_at(l: Leaf, j: usize, m: usize, values: &[f64], at: f64) -> f64 {
    match l {
        Leaf::Slot(h) => values[h.index() * m + j],
        Leaf::Time => at,
        Leaf::Parameter(_) | Leaf::State(_) | Leaf::Input(_) => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Estimator;
    use bondgraph_core::{Options, Realise, ResidualSet};

    /// Everything a run gives, estimate by estimate, as bits.
    #[derive(Debug, PartialEq)]
    struct Run {
        at: Vec<u64>,
        residuals: Vec<u64>,
        bounds: Vec<u64>,
        unsolved: Vec<Option<usize>>,
    }

    impl Run {
        /// Appends a block's estimates.
        fn take(&mut self, e: &Estimates<'_>) {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            self.at.extend(bits(e.at()));
            for j in 0..e.len() {
                for k in 0..e.residual_count() {
                    self.residuals.push(e.residual(k)[j].to_bits());
                    self.bounds.push(e.bound(k)[j].to_bits());
                }
            }
            self.unsolved.extend_from_slice(e.unsolved());
        }
    }

    /// `g` over `time` and `raw`, cut into blocks of the lengths `cuts` gives in turn.
    fn run(mut g: Generator, time: &[f64], raw: &[Vec<f64>], cuts: &[usize]) -> Run {
        let mut out = Run {
            at: Vec::new(),
            residuals: Vec::new(),
            bounds: Vec::new(),
            unsolved: Vec::new(),
        };
        let (mut start, mut cut) = (0, 0);
        while start < time.len() {
            if cuts.is_empty() {
                break;
            }
            let end = (start + cuts[cut % cuts.len()]).min(time.len());
            cut += 1;
            let block: Vec<&[f64]> = raw.iter().map(|c| &c[start..end]).collect();
            out.take(&g.push_block(&time[start..end], &block, true));
            start = end;
        }
        out
    }

    /// Every model of `models/`, with every kind of residual: blocks of any length (one
    /// sample, a few, many) give what one block of the whole record gives, to the bit, with
    /// integrals, roots and copies of the model among them.
    #[test]
    fn every_cut_of_a_record_gives_the_same_estimates() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut paths: Vec<_> = (std::fs::read_dir(dir).expect("models/"))
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "bg"))
            .collect();
        paths.sort();
        let (mut copies, mut roots, mut integrals, mut runs) = (0, 0, 0, 0);
        for path in &paths {
            let text = std::fs::read_to_string(path).expect("a model");
            for (residuals, realise) in [
                (ResidualSet::PerSensor, Realise::Lowest),
                (ResidualSet::All, Realise::Direct),
            ] {
                let options = Options {
                    residuals,
                    realise,
                    ..Options::default()
                };
                let Ok(out) = bondgraph_core::compile(&text, "m.bg", &options) else {
                    continue;
                };
                let c = &out.compiled;
                if c.residual_code_refused() || c.arrs.is_empty() {
                    continue;
                }
                let program = c.program();
                let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
                let fit = Fit {
                    step: 1e-2,
                    estimator: Estimator::SavitzkyGolay {
                        window: 11,
                        degree: program.top_order().max(3),
                    },
                    integration: Vec::new(),
                };
                let make = || Generator::new(c, &program, &params, &fit).expect("valid");
                let g = make();
                copies += usize::from(g.copy.is_some());
                roots += (g.steps.iter())
                    .filter(|s| matches!(s, Step::Root { .. }))
                    .count();
                integrals += (g.steps.iter())
                    .filter(|s| matches!(s, Step::Integral { .. }))
                    .count();
                let time: Vec<f64> = (0..400).map(|k| k as f64 * 1e-2).collect();
                let raw: Vec<Vec<f64>> = (0..program.raw.len())
                    .map(|r| {
                        let w = 0.7 * (r + 1) as f64;
                        time.iter().map(|t| 1.5 + 0.5 * (w * t).sin()).collect()
                    })
                    .collect();
                let whole = run(g, &time, &raw, &[time.len()]);
                assert!(!whole.at.is_empty(), "{}", path.display());
                for cuts in [&[1usize][..], &[3, 1, 7, 2], &[100, 37]] {
                    let cut = run(make(), &time, &raw, cuts);
                    assert!(cut == whole, "{} cut {cuts:?}", path.display());
                }
                // The estimators' output kept from a generator of other parameters gives what
                // computing it again gives.
                let others: Vec<f64> = params.iter().map(|p| p * 1.1).collect();
                let slices: Vec<&[f64]> = raw.iter().map(Vec::as_slice).collect();
                let kept = make().estimated(&time, &slices);
                let mut g = Generator::new(c, &program, &others, &fit).expect("valid");
                let mut from_kept = run(make(), &time, &raw, &[]);
                g.run_estimated(&time, &slices, &kept, true, |e| from_kept.take(e));
                let again = Generator::new(c, &program, &others, &fit).expect("valid");
                let again = run(again, &time, &raw, &[BLOCK]);
                assert!(from_kept == again, "{} kept estimates", path.display());
                // Taken on from a state with the same parameters: the rest of the run.
                let mut head = make();
                let k = 150;
                let slices: Vec<&[f64]> = raw.iter().map(|c| &c[..k]).collect();
                let mut before = run(make(), &time, &raw, &[]);
                head.run(&time[..k], &slices, true, |e| before.take(e));
                let mut resumed = head
                    .with_parameters(c, &program, &params, &fit)
                    .expect("valid");
                let slices: Vec<&[f64]> = raw.iter().map(|c| &c[k..]).collect();
                resumed.run(&time[k..], &slices, true, |e| before.take(e));
                assert!(before == whole, "{} resumed", path.display());
                runs += 1;
            }
        }
        assert!(runs >= 20, "{runs} models ran");
        assert!(
            copies > 0 && roots > 0 && integrals > 0,
            "{copies} {roots} {integrals}"
        );
    }
}
