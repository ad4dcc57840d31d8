//! How a generator estimates and integrates.

use bondgraph::{Differentiator, EstimatorError, ModulatingFunction, Reference, SavitzkyGolay};

/// Over what residuals realised by integration are integrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integration {
    /// The last N samples.
    Window(usize),
    /// From the first estimate.
    Start,
}

impl Default for Integration {
    fn default() -> Self {
        Integration::Window(Reference::DEFAULT_WINDOW)
    }
}

impl Integration {
    /// The runtime reference that takes a running value's change over it.
    pub fn reference(self) -> Reference {
        match self {
            Integration::Window(n) => Reference::window(n),
            Integration::Start => Reference::from_start(),
        }
    }
}

impl std::fmt::Display for Integration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Integration::Window(n) => write!(f, "{n}"),
            Integration::Start => f.write_str("start"),
        }
    }
}

impl std::str::FromStr for Integration {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "start" => Ok(Integration::Start),
            _ => match s.parse::<usize>() {
                Ok(n) if n > 0 => Ok(Integration::Window(n)),
                _ => Err(format!(
                    "expected a number of samples (at least 1) or `start`, not `{s}`"
                )),
            },
        }
    }
}

/// How every channel's value and derivatives are estimated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimator {
    /// Centred Savitzky–Golay fits of `degree` over `window` samples (odd).
    SavitzkyGolay {
        /// Samples in each fit.
        window: usize,
        /// The polynomial's degree.
        degree: u32,
    },
    /// Modulating functions `sᵃ (T − s)ᵃ` over `window` samples (odd), `a` one above the
    /// highest derivative the program reads, the same for every channel (see
    /// [`bondgraph::ModulatingFunction`]).
    Modulating {
        /// Samples in the window.
        window: usize,
    },
}

impl Estimator {
    /// Its window, in samples.
    pub fn window(self) -> usize {
        match self {
            Estimator::SavitzkyGolay { window, .. } | Estimator::Modulating { window } => window,
        }
    }

    /// The degree of the polynomials it follows signals with (modulating functions: a
    /// cubic's, the fits' default).
    pub fn degree(self) -> u32 {
        match self {
            Estimator::SavitzkyGolay { degree, .. } => degree,
            Estimator::Modulating { .. } => 3,
        }
    }

    /// The estimator of a channel read up to `order`, in a program that reads up to `top`,
    /// for samples every `step` seconds.
    pub fn build(
        self,
        order: u32,
        top: u32,
        step: f64,
    ) -> Result<Box<dyn Differentiator + Send>, EstimatorError> {
        Ok(Box::new(self.built(order, top, step)?))
    }

    /// [`Estimator::build`], as a value a generator can clone with its state.
    pub(crate) fn built(self, order: u32, top: u32, step: f64) -> Result<Built, EstimatorError> {
        Ok(match self {
            Estimator::SavitzkyGolay { window, degree } => {
                Built::Fit(SavitzkyGolay::new(order, degree, window, step, true)?)
            }
            Estimator::Modulating { window } => {
                Built::Modulating(ModulatingFunction::new(order, top + 1, window, step)?)
            }
        })
    }
}

/// An estimator as [`Estimator::built`] makes it.
#[derive(Clone, Debug)]
pub(crate) enum Built {
    Fit(SavitzkyGolay),
    Modulating(ModulatingFunction),
}

impl Built {
    fn inner(&mut self) -> &mut dyn Differentiator {
        match self {
            Built::Fit(e) => e,
            Built::Modulating(e) => e,
        }
    }

    fn inner_ref(&self) -> &dyn Differentiator {
        match self {
            Built::Fit(e) => e,
            Built::Modulating(e) => e,
        }
    }
}

impl Differentiator for Built {
    fn push(&mut self, x: f64) -> Option<&[f64]> {
        self.inner().push(x)
    }

    fn delay(&self) -> f64 {
        self.inner_ref().delay()
    }

    fn order(&self) -> u32 {
        self.inner_ref().order()
    }

    fn push_slice(&mut self, xs: &[f64], out: &mut [f64]) -> usize {
        self.inner().push_slice(xs, out)
    }
}

/// How a [`Generator`](crate::Generator) estimates, from samples every `step` seconds, and
/// over what residuals realised by integration are integrated.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// The record's step, in seconds.
    pub step: f64,
    /// How every channel is estimated.
    pub estimator: Estimator,
    /// Over what each integrated residual is taken (by residual; the default past the end).
    pub integration: Vec<Integration>,
}

impl Fit {
    /// Each ARR's memory, in samples: how far one instant of a record reaches its residual
    /// (the estimators' window, plus the window of a residual integrated over one). An
    /// episode counts a residual's alarm once it outlasts that (`Episode::remembering`).
    pub fn memories(&self, arrs: &[bondgraph_core::Arr]) -> Vec<usize> {
        let window = self.estimator.window();
        (arrs.iter().enumerate())
            .map(|(k, a)| {
                let integrated =
                    matches!(a.realisation, bondgraph_core::Realisation::Integrated(_));
                match self.integration.get(k).copied().unwrap_or_default() {
                    Integration::Window(n) if integrated => window + n,
                    _ => window,
                }
            })
            .collect()
    }
}
