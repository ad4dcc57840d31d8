//! The false alarms a calibration is asked for, as the user states them: `1/h`, `0.5/min`,
//! or a share of healthy samples.

use crate::walk::Walk;

/// The false alarms a calibration allows (`--false-alarm-rate`, Python's `false_alarm_rate`):
/// a rate in time, or a share of healthy samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FalseAlarms {
    /// Healthy records crossing a threshold, per second.
    PerSecond(f64),
    /// The share of healthy samples above a threshold (the (1 − P) quantile).
    Share(f64),
}

impl FalseAlarms {
    /// The share of healthy samples above a threshold (0 for a rate in time).
    pub fn share(self) -> f64 {
        match self {
            FalseAlarms::Share(p) => p,
            FalseAlarms::PerSecond(_) => 0.0,
        }
    }

    /// The probability a healthy record of `seconds` crosses a threshold: the rate's share
    /// of it (at most a half: a higher one is no longer a rare event, and the extreme-value
    /// laws the levels come from no longer hold), or [`Walk::CROSSING`] for a share.
    pub fn crossing(self, seconds: f64) -> f64 {
        match self {
            FalseAlarms::PerSecond(r) => (r * seconds).clamp(f64::MIN_POSITIVE, 0.5),
            FalseAlarms::Share(_) => Walk::CROSSING,
        }
    }
}

impl std::str::FromStr for FalseAlarms {
    type Err = String;

    fn from_str(s: &str) -> Result<FalseAlarms, String> {
        let number = |n: &str| -> Result<f64, String> {
            n.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| format!("`{n}`: expected a number at least 0"))
        };
        match s.split_once('/') {
            None => {
                let p = number(s)?;
                if p >= 1.0 {
                    return Err(format!(
                        "`{s}`: a share of samples is below 1; a rate in time is written with \
                         its unit (`1/h`)"
                    ));
                }
                Ok(FalseAlarms::Share(p))
            }
            Some((n, unit)) => {
                let seconds = match unit.trim() {
                    "s" => 1.0,
                    "min" => 60.0,
                    "h" => 3600.0,
                    "d" => 86_400.0,
                    other => {
                        return Err(format!(
                            "`{other}`: expected a unit of time, `s`, `min`, `h` or `d`"
                        ))
                    }
                };
                let n = number(n)?;
                if n == 0.0 {
                    return Err(format!(
                        "`{s}`: no false alarm at all is no threshold; state a rate above 0"
                    ));
                }
                Ok(FalseAlarms::PerSecond(n / seconds))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_false_alarm_rate_is_a_rate_in_time_or_a_share_of_samples() {
        let read = |s: &str| s.parse::<FalseAlarms>();
        assert_eq!(read("1/h"), Ok(FalseAlarms::PerSecond(1.0 / 3600.0)));
        assert_eq!(read("0.5 / min"), Ok(FalseAlarms::PerSecond(0.5 / 60.0)));
        assert_eq!(read("2/d"), Ok(FalseAlarms::PerSecond(2.0 / 86_400.0)));
        assert_eq!(read("0.01"), Ok(FalseAlarms::Share(0.01)));
        assert!(read("1/week").unwrap_err().contains("a unit of time"));
        assert!(read("1.5").unwrap_err().contains("below 1"));
        assert!(read("0/h").unwrap_err().contains("above 0"));
        assert!(read("-1/h").unwrap_err().contains("at least 0"));
        // One an hour over a 200-s healthy record: that record's share of an hour.
        let hourly = FalseAlarms::PerSecond(1.0 / 3600.0).crossing(200.0);
        assert!((hourly - 200.0 / 3600.0).abs() < 1e-15, "{hourly}");
        assert_eq!(FalseAlarms::Share(0.0).crossing(200.0), Walk::CROSSING);
        assert_eq!(FalseAlarms::PerSecond(1.0).crossing(200.0), 0.5);
    }
}
