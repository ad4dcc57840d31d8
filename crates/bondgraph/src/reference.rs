//! The residual of an ARR realised by integration: the change of its running integral since a
//! reference instant.

use crate::window::Window;

/// Turns the running value `G(t) = F(t) + ∫ A dt` of an integrated ARR (`r = A + dF/dt`) into
/// its residual `G(t) − G(t₀) = ∫_{t₀}^t r dt`, which is zero while the machine is healthy
/// whatever the state it started in.
///
/// Over a moving window of `n` samples (the default, [`Reference::DEFAULT_WINDOW`]),
/// `t₀ = t − n·step`: the residual is the relation averaged over the window (times its
/// length), whose noise and whose share of a slow model error stay bounded, so a threshold
/// calibrated on one healthy record holds on another. A fault that moves the relation for as
/// long as it lasts moves the residual as long; one that shows only while a signal moves (a
/// wider dead zone, seen through its rate while the shafts turn) shows for `n` samples after
/// each motion.
///
/// From the start, `t₀` is the first instant: such a fault leaves the residual offset for
/// good, but the noise integrated with it grows like the square root of the record's length
/// and a model error grows with it, so thresholds must allow for the longest record.
#[derive(Clone, Debug)]
pub struct Reference {
    kind: Kind,
}

#[derive(Clone, Debug)]
enum Kind {
    Start(Option<f64>),
    Window(Window<f64>),
}

impl Reference {
    /// The window of [`Reference::default`], in samples.
    pub const DEFAULT_WINDOW: usize = 250;

    /// The change since the first value.
    #[must_use]
    pub fn from_start() -> Reference {
        Reference {
            kind: Kind::Start(None),
        }
    }

    /// The change over the last `samples` steps (at least one).
    #[must_use]
    pub fn window(samples: usize) -> Reference {
        Reference {
            kind: Kind::Window(Window::new(samples.max(1) + 1, 0.0)),
        }
    }

    /// Takes the running value at the next sample and returns the residual; over a window,
    /// zero until the window has filled.
    #[inline]
    pub fn push(&mut self, g: f64) -> f64 {
        match &mut self.kind {
            Kind::Start(start) => g - *start.get_or_insert(g),
            Kind::Window(window) => window.push(g).map_or(0.0, |w| g - w[0]),
        }
    }
}

impl Reference {
    /// [`Reference::push`] of each running value of `g` in turn, each replaced by its
    /// residual.
    pub fn push_slice(&mut self, g: &mut [f64]) {
        for g in g {
            *g = self.push(*g);
        }
    }
}

impl Default for Reference {
    fn default() -> Self {
        Reference::window(Reference::DEFAULT_WINDOW)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_the_start_the_first_value_is_the_reference() {
        let mut r = Reference::from_start();
        assert_eq!(r.push(3.0), 0.0);
        assert_eq!(r.push(5.0), 2.0);
        assert_eq!(r.push(2.5), -0.5);
    }

    #[test]
    fn over_a_window_the_reference_is_the_value_that_many_steps_back() {
        let mut r = Reference::window(2);
        assert_eq!(r.push(1.0), 0.0);
        assert_eq!(r.push(2.0), 0.0);
        assert_eq!(r.push(4.0), 3.0);
        assert_eq!(r.push(8.0), 6.0);
        assert_eq!(r.push(8.0), 4.0);
    }
}
