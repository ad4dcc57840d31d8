//! The residual generator of a program, run sample by sample.

use bondgraph::{Differentiator, EstimatorError, Reference, RootFinder, Trapezoid};
use bondgraph_core::program::{Code, Evaluation, Fill, Leaf, Program, Source};
use bondgraph_core::{Compiled, Tape};

use crate::copy::CopyRun;
use crate::fit::Fit;
use crate::fold::tape;

/// What one channel of the bank is fed from the raw samples.
enum Feed {
    Raw(usize),
    Integral(usize, Trapezoid),
}

/// A slot filled at the estimates' instant from the slots before it.
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
/// order, as the generated `ResidualGenerator` of the same program.
pub struct Generator {
    /// One estimator per channel, and what it is fed.
    estimators: Vec<Box<dyn Differentiator + Send>>,
    feeds: Vec<Feed>,
    /// For each channel, the slots of the derivatives read, by order.
    scatter: Vec<Vec<(usize, usize)>>,
    steps: Vec<Step>,
    /// The slot of the first root not found at the last estimate, if any.
    unsolved: Option<usize>,
    residuals: Tape<Leaf>,
    /// Every sensitivity `∂r/∂θ` of every residual, in order.
    sensitivities: Tape<Leaf>,
    /// For each of them, its residual and `Δθ`.
    weights: Vec<(usize, f64)>,
    /// Each residual realised by integration, with its reference.
    references: Vec<(usize, Reference)>,
    /// The copy of the model simulated residuals run, if any.
    copy: Option<CopyRun>,
    delay: f64,
    values: Vec<f64>,
    /// Reused between samples, so that a sample allocates nothing.
    scratch: Vec<f64>,
    buffer: Vec<f64>,
    out: Vec<f64>,
    bounds: Vec<f64>,
}

/// The residuals at one instant, as [`Generator::push`] gives them.
pub struct Estimate<'g> {
    /// The instant of the estimates: the sample's time minus the estimators' delay.
    pub at: f64,
    /// Each residual.
    pub residuals: &'g [f64],
    /// Each residual's bound from parameter uncertainty (zeros when not asked for).
    pub bounds: &'g [f64],
    /// The slot of the first root not found at this instant (the residuals that read it are
    /// not numbers), if any.
    pub unsolved: Option<usize>,
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
        let fit = |order: u32| how.estimator.build(order, top, how.step);
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
        Ok(Generator {
            estimators,
            feeds,
            scatter,
            steps,
            unsolved: None,
            residuals: tape(&program.code, &residuals, params),
            sensitivities: tape(&program.code, &sensitivities, params),
            weights,
            references,
            copy: (program.copy.as_ref()).map(|copy| CopyRun::new(program, copy, params)),
            delay,
            values: vec![0.0; program.slots.len()],
            scratch: Vec::new(),
            buffer: Vec::new(),
            out: Vec::new(),
            bounds: Vec::new(),
        })
    }

    /// Takes the raw samples at `t` (in the program's raw order, one per raw signal: a
    /// shorter slice is a caller's bug and panics) and returns, once the
    /// windows are full, the residuals at the instant of the estimates and, with `bounds`,
    /// each residual's bound from parameter uncertainty, `Σ |∂r/∂θ| Δθ` (else zeros).
    pub fn push(&mut self, t: f64, raw: &[f64], bounds: bool) -> Option<Estimate<'_>> {
        if let Some(copy) = &mut self.copy {
            copy.push(t, raw);
        }
        if !self.estimate(t, raw) {
            return None;
        }
        let at = t - self.delay;
        if let Some(copy) = &mut self.copy {
            let x = copy.replay.at(at)?;
            for &(i, k) in &copy.read {
                self.values[i] = x[k];
            }
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        let mut buffer = std::mem::take(&mut self.buffer);
        self.unsolved = None;
        let mut steps = std::mem::take(&mut self.steps);
        for step in &mut steps {
            match step {
                Step::Integral {
                    slot,
                    integrand,
                    rule,
                } => {
                    let leaf = |l| self.leaf(l, at);
                    integrand.values_into(leaf, |_| f64::NAN, &mut scratch, &mut buffer);
                    let v = buffer[0];
                    self.values[*slot] = rule.push(at, v);
                }
                Step::Root { slot, law, finder } => {
                    let root = finder.solve(|z| {
                        self.values[*slot] = z;
                        let leaf = |l| self.leaf(l, at);
                        law.values_into(leaf, |_| f64::NAN, &mut scratch, &mut buffer);
                        (buffer[0], buffer[1])
                    });
                    self.values[*slot] = match root {
                        Some(z) => z,
                        // No root at this instant: what reads it is not a number, and the
                        // estimate says which slot was unsolved.
                        None => {
                            self.unsolved = self.unsolved.or(Some(*slot));
                            f64::NAN
                        }
                    };
                }
            }
        }
        self.steps = steps;
        let mut out = std::mem::take(&mut self.out);
        (self.residuals).values_into(|l| self.leaf(l, at), |_| f64::NAN, &mut scratch, &mut out);
        for (k, reference) in &mut self.references {
            if let Some(r) = out.get_mut(*k) {
                *r = reference.push(*r);
            }
        }
        self.bounds.clear();
        self.bounds.resize(out.len(), 0.0);
        if bounds && !self.weights.is_empty() {
            let leaf = |l| self.leaf(l, at);
            (self.sensitivities).values_into(leaf, |_| f64::NAN, &mut scratch, &mut buffer);
            for (&(k, delta), s) in self.weights.iter().zip(&buffer) {
                self.bounds[k] += s.abs() * delta;
            }
        }
        self.scratch = scratch;
        self.buffer = buffer;
        self.out = out;
        Some(Estimate {
            at,
            residuals: &self.out,
            bounds: &self.bounds,
            unsolved: self.unsolved,
        })
    }

    /// Feeds every channel its sample and writes the estimates into their slots; whether
    /// every window is full.
    fn estimate(&mut self, t: f64, raw: &[f64]) -> bool {
        let mut ready = true;
        let channels = self.estimators.iter_mut().zip(&mut self.feeds);
        for (c, (estimator, feed)) in channels.enumerate() {
            let x = match feed {
                Feed::Raw(k) => raw[*k],
                Feed::Integral(k, rule) => rule.push(t, raw[*k]),
            };
            match estimator.push(x) {
                Some(d) => {
                    for &(n, i) in &self.scatter[c] {
                        self.values[i] = d[n];
                    }
                }
                None => ready = false,
            }
        }
        ready
    }

    fn leaf(&self, l: Leaf, at: f64) -> f64 {
        match l {
            Leaf::Slot(h) => self.values[h.index()],
            Leaf::Time => at,
            // Folded, or read only by the copy's rates.
            Leaf::Parameter(_) | Leaf::State(_) | Leaf::Input(_) => f64::NAN,
        }
    }
}
