//! Alarms from residuals.

/// A fixed threshold on |residual| with a debounce: the alarm rises after `debounce`
/// consecutive samples above the level and falls after as many below it, so that a single
/// noisy sample neither raises nor clears it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Threshold {
    level: f64,
    debounce: u32,
    count: u32,
    alarm: bool,
}

impl Threshold {
    /// A threshold at `level` (on the absolute value) that needs `debounce` consecutive
    /// samples (at least 1) to change its decision.
    #[must_use]
    pub fn new(level: f64, debounce: u32) -> Threshold {
        Threshold {
            level,
            debounce: debounce.max(1),
            count: 0,
            alarm: false,
        }
    }

    /// Takes one residual sample and returns whether the alarm is on.
    #[inline]
    pub fn update(&mut self, residual: f64) -> bool {
        // A residual that is not a number is as alarming as a large one.
        let above = residual.is_nan() || residual.abs() > self.level;
        if above != self.alarm {
            self.count += 1;
            if self.count >= self.debounce {
                self.alarm = above;
                self.count = 0;
            }
        } else {
            self.count = 0;
        }
        self.alarm
    }

    /// [`Threshold::update`] against a level that moves with the operating point (an
    /// adaptive threshold), which stays the level from then on.
    #[inline]
    pub fn update_with_level(&mut self, residual: f64, level: f64) -> bool {
        self.level = level;
        self.update(residual)
    }

    /// Whether the alarm is on.
    #[must_use]
    pub fn alarm(&self) -> bool {
        self.alarm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_alarm_needs_debounce_samples_to_rise_and_to_fall() {
        let mut th = Threshold::new(1.0, 3);
        let seen: Vec<bool> = [2.0, 0.0, 2.0, -2.0, 2.0, 0.5, 0.5, 0.5]
            .iter()
            .map(|&r| th.update(r))
            .collect();
        assert_eq!(seen, [false, false, false, false, true, true, true, false]);
        assert!(Threshold::new(1.0, 1).update(f64::NAN));
    }
}
