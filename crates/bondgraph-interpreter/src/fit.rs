//! How a generator estimates and integrates.

use bondgraph::Reference;

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

/// How a [`Generator`](crate::Generator) estimates: Savitzky–Golay fits of `degree` over
/// `window` samples every `step` seconds, and over what residuals realised by integration are
/// integrated.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// The record's step, in seconds.
    pub step: f64,
    /// Samples in each fit (odd).
    pub window: usize,
    /// The fits' polynomial degree.
    pub degree: u32,
    /// Over what each integrated residual is taken (by residual; the default past the end).
    pub integration: Vec<Integration>,
}
