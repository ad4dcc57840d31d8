//! The second test on an integrated residual: what holds a persistent fault in alarm after the
//! short window that catches its onset has let it go, and lets an intermittent one end.
//!
//! An integrated residual is `S(t) − S(t₀)`, `S` its running integral. Its onset test reads
//! the relation over a short window (a quarter of the estimators'): a fault shows there
//! within a few samples and leaves it as soon, so an intermittent fault's alarm ends with it.
//! But a fault that moves the relation only while a signal moves (a wider dead zone, seen
//! while the shafts turn), or too little for a short window's noise, leaves it too, while it
//! persists. The hold reads the same running integral over a longer reach:
//! - from the start, where the relation reads a signal integrated from the start (the
//!   bench's twist): its integral from the start is the balance itself (the link's torque),
//!   whose offset is the fault present now, not the trace of a past one;
//! - else over a longer window, restarted where an onset alarm ends that raised it: a pulse
//!   the onset test saw begin and end is not held for a window's length after it, while a
//!   fault the hold carried before the pulse is held through it.

use bondgraph::Reference;

use crate::fit::Integration;
use crate::walk::Walk;

/// How a residual's hold reads its running integral, and what raises it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Over how long: a window of samples, or from the start.
    pub integration: Integration,
    /// Anchored (never restarted: the integral from the start is the balance itself), or
    /// restarted where an onset alarm that raised it ends.
    pub anchored: bool,
    /// Its threshold (in its walk's deviations where it has one).
    pub level: f64,
    /// The walk its threshold grows with, from the start.
    pub walk: Option<Walk>,
}

/// One residual's hold as a record is read: its running integral's past values over the
/// window and where it was last restarted.
#[derive(Clone, Debug)]
pub struct Holding {
    hold: Hold,
    /// The onset test's window over the same running integral.
    onset: Reference,
    /// The running integral's values over the window, oldest first, as a ring.
    past: Vec<f64>,
    next: usize,
    filled: bool,
    /// The running integral where the hold was last restarted, and the samples since.
    restart: Option<(f64, usize)>,
    /// The first value seen: what the hold reads from, from the start.
    first: Option<f64>,
    /// Whether the hold had been in alarm for longer than the onset window when the onset
    /// test's current alarm rose; and for how many samples it has been.
    held_before: bool,
    held_for: usize,
    /// The onset window, in samples.
    onset_window: usize,
    onset_was: bool,
    on: bool,
    value: f64,
    threshold: f64,
}

impl Holding {
    /// A hold on a residual whose running integral is fed, sample by sample, to
    /// [`Holding::onset`] then [`Holding::update`]; its onset test reads it over `onset`
    /// samples.
    pub fn new(hold: Hold, onset: usize) -> Holding {
        let length = match hold.integration {
            Integration::Window(n) => n.max(1) + 1,
            Integration::Start => 0,
        };
        Holding {
            hold,
            onset: Reference::window(onset),
            past: vec![0.0; length],
            next: 0,
            filled: false,
            restart: None,
            first: None,
            held_before: false,
            held_for: 0,
            onset_window: onset,
            onset_was: false,
            on: false,
            value: 0.0,
            threshold: hold.level,
        }
    }

    /// The onset test's residual at the next estimate, from the running integral `s` there
    /// (the relation over the onset window, as a generator integrating over it gives it).
    pub fn onset(&mut self, s: f64) -> f64 {
        self.onset.push(s)
    }

    /// What it holds by.
    pub fn hold(&self) -> &Hold {
        &self.hold
    }

    /// Takes the running integral `s` at the next estimate (the `k`th from the start), with
    /// the onset test's alarm there, and returns whether the hold is in alarm; `decides` is
    /// false where no threshold applies (a singular or unsettled sample). A residual that is
    /// not a number leaves the hold as it was.
    pub fn update(&mut self, s: f64, k: usize, onset: bool, decides: bool) -> bool {
        if !s.is_finite() {
            return self.on && decides;
        }
        let first = *self.first.get_or_insert(s);
        let back = self.reference(s, first);
        self.value = s - back;
        if let Some((_, since)) = self.restart.as_mut() {
            *since += 1;
        }
        self.threshold = match self.hold.walk {
            Some(w) => w.threshold(self.hold.level, k),
            None => self.hold.level,
        };
        self.on = decides && self.value.abs() > self.threshold;
        self.held_for = if self.on { self.held_for + 1 } else { 0 };
        // An onset alarm that rose with the hold off and ends with it on raised it: the
        // hold starts again from here, unless the integral from the start is the balance.
        // The hold may rise a little before the onset test on the same fault (a longer
        // window sees an offset sooner): held for no longer than the onset window, it was
        // raised by what the onset test saw. So does an onset alarm that ends before the
        // window has filled: what it saw would come into the hold once it filled, with no
        // onset alarm left to end it.
        if onset && !self.onset_was {
            self.held_before = self.held_for > self.onset_window;
        }
        let raised = self.on && !self.held_before;
        let unfilled = !self.filled && matches!(self.hold.integration, Integration::Window(_));
        if !onset && self.onset_was && (raised || unfilled) && !self.hold.anchored {
            self.restart = Some((s, 0));
            self.value = 0.0;
            self.on = false;
            self.held_for = 0;
        }
        self.onset_was = onset;
        self.on
    }

    /// The hold's value at the last estimate: the running integral's change over its reach.
    pub fn value(&self) -> f64 {
        self.value
    }

    /// The hold's threshold at the last estimate.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// The running integral at the start of the hold's reach now, after taking `s` in.
    fn reference(&mut self, s: f64, first: f64) -> f64 {
        let restarted = self.restart.map(|(at, _)| at);
        match self.hold.integration {
            Integration::Start => restarted.unwrap_or(first),
            Integration::Window(_) => {
                let n = self.past.len();
                self.past[self.next] = s;
                self.next = (self.next + 1) % n;
                self.filled |= self.next == 0;
                // Zero until the window has filled, as calibration read it (from the first
                // value, a start-up the healthy record never showed the hold would raise
                // it); a restart there reads from the restart.
                let window_back = if self.filled { self.past[self.next] } else { s };
                match self.restart {
                    // The window reaches back past the restart: from the restart.
                    Some((at, since)) if since + 1 < n => at,
                    _ => window_back,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(n: usize, level: f64) -> Holding {
        let hold = Hold {
            integration: Integration::Window(n),
            anchored: false,
            level,
            walk: None,
        };
        Holding::new(hold, 1)
    }

    #[test]
    fn over_a_window_the_value_is_the_change_over_it() {
        let mut h = window(2, 10.0);
        let s = [1.0, 2.0, 4.0, 8.0, 8.0];
        let values: Vec<f64> = (s.iter().enumerate())
            .map(|(k, &s)| {
                h.update(s, k, false, true);
                h.value()
            })
            .collect();
        assert_eq!(values, [0.0, 0.0, 3.0, 6.0, 4.0]);
    }

    #[test]
    fn a_pulse_the_onset_saw_begin_and_end_is_not_held_after_it() {
        // A pulse adds 1 per sample for 5 samples, the window full; the window is 20 samples, the level 2.
        let mut h = window(20, 2.0);
        let mut s = 0.0;
        let mut held = Vec::new();
        for k in 0..100 {
            let pulse = (40..45).contains(&k);
            if pulse {
                s += 1.0;
            }
            held.push(h.update(s, k, pulse || k == 45, true));
        }
        assert!(held[42..45].iter().all(|&on| on), "held during the pulse");
        assert!(held[46..].iter().all(|&on| !on), "ended with it: {held:?}");
    }

    #[test]
    fn a_pulse_before_the_window_has_filled_is_not_held_once_it_has() {
        let mut h = window(50, 2.0);
        let mut s = 0.0;
        let mut held = Vec::new();
        for k in 0..150 {
            let pulse = (10..15).contains(&k);
            if pulse {
                s += 1.0;
            }
            held.push(h.update(s, k, pulse || k == 15, true));
        }
        assert!(held.iter().all(|&on| !on), "{held:?}");
    }

    #[test]
    fn a_pulse_the_hold_saw_a_little_before_the_onset_is_not_held_after_it() {
        // The onset test (window 4) rises 3 samples after the hold does.
        let hold = Hold {
            integration: Integration::Window(20),
            anchored: false,
            level: 2.0,
            walk: None,
        };
        let mut h = Holding::new(hold, 4);
        let mut s = 0.0;
        let mut held = Vec::new();
        for k in 0..100 {
            if (40..45).contains(&k) {
                s += 1.0;
            }
            held.push(h.update(s, k, (45..50).contains(&k), true));
        }
        assert!(held[42], "{held:?}");
        assert!(held[50..].iter().all(|&on| !on), "{held:?}");
    }

    #[test]
    fn a_fault_held_before_a_pulse_is_held_through_and_after_it() {
        // A persistent drift of 0.5 per sample from sample 0; a pulse of the onset test
        // from 30 to 35.
        let mut h = window(20, 2.0);
        let held: Vec<bool> = (0..80)
            .map(|k| h.update(0.5 * k as f64, k, (30..35).contains(&k), true))
            .collect();
        assert!(held[25..].iter().all(|&on| on), "{held:?}");
    }

    #[test]
    fn a_persistent_fault_is_held_again_after_the_restart() {
        // A fault that adds 1 per sample from sample 60 on; the onset test sees its first
        // 10 samples only.
        let mut h = window(50, 8.0);
        let mut s = 0.0;
        let mut held = Vec::new();
        for k in 0..150 {
            if k >= 60 {
                s += 1.0;
            }
            held.push(h.update(s, k, (60..70).contains(&k), true));
        }
        assert!(held[68], "{held:?}");
        let gap = held[70..].iter().position(|&on| on);
        assert!(gap.is_some_and(|g| (1..=10).contains(&g)), "{held:?}");
        assert!(held[85..].iter().all(|&on| on), "{held:?}");
    }

    #[test]
    fn the_onset_window_is_the_change_over_it() {
        let mut h = window(20, 1.0);
        let mut h2 = Holding::new(*h.hold(), 2);
        let got: Vec<f64> = [1.0, 2.0, 4.0, 8.0].iter().map(|&s| h2.onset(s)).collect();
        assert_eq!(got, [0.0, 0.0, 3.0, 6.0]);
        assert_eq!(h.onset(5.0), 0.0);
    }

    #[test]
    fn anchored_from_the_start_an_offset_is_held_for_good() {
        let hold = Hold {
            integration: Integration::Start,
            anchored: true,
            level: 1.0,
            walk: None,
        };
        let mut h = Holding::new(hold, 1);
        let held: Vec<bool> = (0..40)
            .map(|k| {
                let s = if k >= 10 { 3.0 } else { 0.0 };
                h.update(s, k, (10..14).contains(&k), true)
            })
            .collect();
        assert!(held[10..].iter().all(|&on| on));
        assert!(held[..10].iter().all(|&on| !on));
    }
}
