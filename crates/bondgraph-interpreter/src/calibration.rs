//! A calibration kept: what `bgc residuals --calibrate` chose (the parameters as fitted, the
//! estimator, each residual's integration, threshold and noise walk), written to a file that
//! `--calibration` reads back, so that monitoring runs without recalibrating and decides as
//! the calibration did. The file names the model it is for by a hash of its text and is
//! refused for another.
//!
//! The format is text, a line per item, `#` for comments:
//!
//! ```text
//! bgc-calibration 1
//! model "models/backlash_bench.bg" fnv1a64 5f0c6e2a9d1b3c47
//! residuals per-sensor lowest
//! healthy "healthy.csv" rows 200001 step 0.001
//! crossing 0.001
//! start-up 0.994
//! estimator savitzky-golay 201 3
//! param ke 0.5082694886183107
//! noise y1 1.0e-4
//! combined Re L Je fe K Js fs
//! range y1 -4.1 12.7
//! arr ARR1 start 7.1e-3 walk 1.2e-6 3.4e-11
//! arr ARR2 250 1.5e-2 typical 2.2e-5
//! ```
//!
//! `start-up SECONDS`: where the healthy record started unsettled, how long it took to
//! settle; every record monitored is left undecided at least that long (none where it
//! started settled).
//! `noise SIGNAL DEVIATION`: a signal's noise as read on the healthy record, for the samples
//! where a residual is singular (see `Conditioning`); none where no residual can be.
//! `combined NAME…`: parameters the calibration's fit found determined only together (the
//! records hold them only in combination), so that a fault's size on one is a ratio only.
//! `range SIGNAL LEAST MOST`: a signal's range on the healthy record, what the thresholds
//! hold over (a record beyond it is said to be).
//! `arr NAME INTEGRATION THRESHOLD [walk FLOOR RATE [drift PER_SAMPLE]] [typical SENSITIVITY]
//! [cusum SIGMA DRIFT LEVEL]`: the integration is `start`, a window in samples, or `-` for a
//! residual not integrated; the threshold is `-` for none, and for a residual with a walk it
//! is in the walk's deviations, plus the drift allowed for times the samples from the start; `typical`, the residual's median sensitivity to that noise on the
//! healthy record; `cusum`, the sequential test beside the threshold (`--cusum`);
//! `hold INTEGRATION anchored|restarted LEVEL [hold-walk FLOOR RATE [hold-drift PER_SAMPLE]]`,
//! the second test of an integrated residual whose integration is then its onset window
//! (see `Hold`).

use crate::calibrate::{Conditioning, CusumLevels, Range};
use crate::fit::{Estimator, Integration};
use crate::hold::Hold;
use crate::walk::Walk;

/// The format's version, the file's first line.
const HEADER: &str = "bgc-calibration 1";

/// One residual's part of a calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct Decision {
    /// The ARR's name.
    pub name: String,
    /// Its integration, where it is integrated.
    pub integration: Option<Integration>,
    /// Its threshold (in its walk's deviations where it has one), where it has one.
    pub threshold: Option<f64>,
    /// Its noise's walk, where it is integrated from the start.
    pub walk: Option<Walk>,
    /// Its median sensitivity to the signals' noise on the healthy record, where it can be
    /// singular.
    pub typical: Option<f64>,
    /// Its CUSUM beside the threshold, where it has one.
    pub cusum: Option<CusumLevels>,
    /// Its hold, where it has one.
    pub hold: Option<Hold>,
}

/// What monitoring runs with, as `--calibrate` chose it.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The model's file name, as given when calibrating (for the reader).
    pub model: String,
    /// The FNV-1a hash of the model's text.
    pub hash: u64,
    /// `--residuals` and `--realise`, as their values are spelled.
    pub residuals: (String, String),
    /// The healthy record's name, rows and step.
    pub healthy: (String, usize, f64),
    /// The probability a healthy record of the healthy one's length crosses a threshold.
    pub crossing: f64,
    /// Where the healthy record started unsettled, the seconds it took to settle (see
    /// `Conditioning::start_up`).
    pub start_up: Option<f64>,
    /// The signals' estimator.
    pub estimator: Estimator,
    /// Each parameter's value, in the model's order.
    pub params: Vec<(String, f64)>,
    /// Each raw signal's noise deviation on the healthy record, in the program's order;
    /// empty where no residual can be singular.
    pub noise: Vec<(String, f64)>,
    /// Each residual's integration and threshold, in the model's order.
    pub decisions: Vec<Decision>,
    /// The combinations of parameters the calibration's fit found determined only together,
    /// by name (`combined NAME NAME…`): a fault's size on one of them is a ratio only.
    pub combined: Vec<Vec<String>>,
    /// Each raw signal's range on the healthy record (`range SIGNAL LEAST MOST`), in the
    /// program's order; what the thresholds hold over.
    pub ranges: Vec<(String, Range)>,
}

/// The 64-bit FNV-1a hash of `bytes`: enough to tell one model's text from another's
/// (not a defence against forgery, which a calibration file does not need).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A number as the file holds it: the shortest text that reads back to the same value.
fn number(x: f64) -> String {
    // Rust prints a float as the shortest text that reads back to it.
    format!("{x:?}")
}

/// An integration as the file writes it.
fn integration_word(i: Integration) -> String {
    match i {
        Integration::Start => "start".to_string(),
        Integration::Window(n) => n.to_string(),
    }
}

/// An integration as the file writes it, read back.
fn integration_read(word: &str) -> Result<Integration, String> {
    match word {
        "start" => Ok(Integration::Start),
        n => Ok(Integration::Window(count(n)?)),
    }
}

/// A name quoted, with `"` and `\` escaped.
fn quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

impl Calibration {
    /// The file's text.
    pub fn write(&self) -> String {
        let mut out = format!(
            "{HEADER}\n# Written by `bgc residuals --calibrate`; read by `--calibration`.\n"
        );
        out += &format!("model {} fnv1a64 {:016x}\n", quoted(&self.model), self.hash);
        out += &format!("residuals {} {}\n", self.residuals.0, self.residuals.1);
        let (name, rows, step) = &self.healthy;
        out += &format!(
            "healthy {} rows {rows} step {}\n",
            quoted(name),
            number(*step)
        );
        out += &format!("crossing {}\n", number(self.crossing));
        if let Some(seconds) = self.start_up {
            out += &format!("start-up {}\n", number(seconds));
        }
        out += &match self.estimator {
            Estimator::SavitzkyGolay { window, degree } => {
                format!("estimator savitzky-golay {window} {degree}\n")
            }
            Estimator::Modulating { window } => format!("estimator modulating {window}\n"),
        };
        for (name, value) in &self.params {
            out += &format!("param {name} {}\n", number(*value));
        }
        for (name, deviation) in &self.noise {
            out += &format!("noise {name} {}\n", number(*deviation));
        }
        for names in &self.combined {
            out += &format!("combined {}\n", names.join(" "));
        }
        for (name, r) in &self.ranges {
            out += &format!("range {name} {} {}\n", number(r.least), number(r.most));
        }
        for d in &self.decisions {
            let integration = d.integration.map_or("-".to_string(), integration_word);
            let threshold = d.threshold.map_or("-".to_string(), number);
            out += &format!("arr {} {integration} {threshold}", d.name);
            if let Some(w) = d.walk {
                out += &format!(" walk {} {}", number(w.floor), number(w.rate));
                if w.drift > 0.0 {
                    out += &format!(" drift {}", number(w.drift));
                }
            }
            if let Some(typical) = d.typical {
                out += &format!(" typical {}", number(typical));
            }
            if let Some(c) = d.cusum {
                out += &format!(
                    " cusum {} {} {}",
                    number(c.sigma),
                    number(c.drift),
                    number(c.level)
                );
            }
            if let Some(h) = d.hold {
                out += &format!(
                    " hold {} {} {}",
                    integration_word(h.integration),
                    if h.anchored { "anchored" } else { "restarted" },
                    number(h.level)
                );
                if let Some(w) = h.walk {
                    out += &format!(" hold-walk {} {}", number(w.floor), number(w.rate));
                    if w.drift > 0.0 {
                        out += &format!(" hold-drift {}", number(w.drift));
                    }
                }
            }
            out += "\n";
        }
        out
    }

    /// Reads a calibration file's text; an error names the line and what it expected.
    pub fn parse(text: &str) -> Result<Calibration, String> {
        let mut lines = (text.lines().enumerate())
            .map(|(k, l)| (k + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        match lines.next() {
            Some((_, HEADER)) => {}
            Some((k, l)) => {
                return Err(format!(
                    "line {k}: `{l}`: expected `{HEADER}` (a file `bgc residuals --calibrate \
                     ... --save-calibration` wrote)"
                ))
            }
            None => return Err(format!("empty: expected `{HEADER}`")),
        }
        let mut parts = Parts::default();
        for (k, line) in lines {
            parts
                .line(line)
                .map_err(|e| format!("line {k}: `{line}`: {e}"))?;
        }
        parts.finish()
    }
}

/// A calibration's lines as read so far.
#[derive(Default)]
struct Parts {
    model: Option<(String, u64)>,
    residuals: Option<(String, String)>,
    healthy: Option<(String, usize, f64)>,
    crossing: Option<f64>,
    start_up: Option<f64>,
    estimator: Option<Estimator>,
    params: Vec<(String, f64)>,
    noise: Vec<(String, f64)>,
    decisions: Vec<Decision>,
    combined: Vec<Vec<String>>,
    ranges: Vec<(String, Range)>,
}

impl Parts {
    /// Reads one line.
    fn line(&mut self, line: &str) -> Result<(), String> {
        let words = words(line)?;
        let words: Vec<&str> = words.iter().map(String::as_str).collect();
        match words.as_slice() {
            ["model", name, "fnv1a64", hash] => {
                let hash = u64::from_str_radix(hash, 16)
                    .map_err(|_| format!("`{hash}`: expected 16 hexadecimal digits"))?;
                self.model = Some((name.to_string(), hash));
            }
            ["residuals", set, how] => self.residuals = Some((set.to_string(), how.to_string())),
            ["healthy", name, "rows", rows, "step", step] => {
                let rows = rows
                    .parse()
                    .map_err(|_| format!("`{rows}`: expected a count of rows"))?;
                self.healthy = Some((name.to_string(), rows, positive(step)?));
            }
            ["crossing", p] => self.crossing = Some(positive(p)?),
            ["start-up", s] => self.start_up = Some(positive(s)?),
            ["estimator", "savitzky-golay", window, degree] => {
                self.estimator = Some(Estimator::SavitzkyGolay {
                    window: count(window)?,
                    degree: degree
                        .parse()
                        .map_err(|_| format!("`{degree}`: expected a polynomial degree"))?,
                });
            }
            ["estimator", "modulating", window] => {
                self.estimator = Some(Estimator::Modulating {
                    window: count(window)?,
                });
            }
            ["param", name, value] => self.params.push((name.to_string(), finite(value)?)),
            ["noise", name, deviation] => self
                .noise
                .push((name.to_string(), non_negative(deviation)?)),
            ["range", name, least, most] => {
                let (least, most) = (finite(least)?, finite(most)?);
                if least > most {
                    return Err(format!("`{least} {most}`: expected the least value first"));
                }
                self.ranges.push((name.to_string(), Range { least, most }));
            }
            ["combined", first, rest @ ..] if !rest.is_empty() => self.combined.push(
                std::iter::once(first)
                    .chain(rest)
                    .map(|n| n.to_string())
                    .collect(),
            ),
            ["arr", name, integration, threshold, rest @ ..] => {
                let integration = match *integration {
                    "-" => None,
                    word => Some(integration_read(word)?),
                };
                let threshold = match *threshold {
                    "-" => None,
                    t => Some(non_negative(t)?),
                };
                let (mut walk, mut typical, mut cusum) = (None, None, None);
                let mut hold: Option<Hold> = None;
                let mut rest = rest;
                loop {
                    rest = match rest {
                        [] => break,
                        ["walk", floor, rate, more @ ..] if walk.is_none() => {
                            walk = Some(Walk {
                                floor: non_negative(floor)?,
                                rate: non_negative(rate)?,
                                drift: 0.0,
                            });
                            more
                        }
                        ["drift", value, more @ ..] => {
                            let w = walk.as_mut().ok_or("`drift` before `walk`")?;
                            w.drift = non_negative(value)?;
                            more
                        }
                        ["typical", value, more @ ..] if typical.is_none() => {
                            typical = Some(positive(value)?);
                            more
                        }
                        ["cusum", sigma, drift, level, more @ ..] if cusum.is_none() => {
                            cusum = Some(CusumLevels {
                                sigma: positive(sigma)?,
                                drift: non_negative(drift)?,
                                level: positive(level)?,
                            });
                            more
                        }
                        ["hold", reach, how, level, more @ ..] if hold.is_none() => {
                            hold = Some(Hold {
                                integration: integration_read(reach)?,
                                anchored: match *how {
                                    "anchored" => true,
                                    "restarted" => false,
                                    _ => {
                                        return Err(format!(
                                            "`{how}`: expected `anchored` or `restarted`"
                                        ))
                                    }
                                },
                                level: non_negative(level)?,
                                walk: None,
                            });
                            more
                        }
                        ["hold-walk", floor, rate, more @ ..] => {
                            let h = hold.as_mut().ok_or("`hold-walk` before `hold`")?;
                            h.walk = Some(Walk {
                                floor: non_negative(floor)?,
                                rate: non_negative(rate)?,
                                drift: 0.0,
                            });
                            more
                        }
                        ["hold-drift", value, more @ ..] => {
                            let w = (hold.as_mut().and_then(|h| h.walk.as_mut()))
                                .ok_or("`hold-drift` before `hold-walk`")?;
                            w.drift = non_negative(value)?;
                            more
                        }
                        _ => {
                            return Err("expected nothing after the threshold but `walk FLOOR \
                                        RATE`, `drift PER_SAMPLE`, `typical SENSITIVITY`, \
                                        `cusum SIGMA DRIFT LEVEL` and `hold INTEGRATION \
                                        anchored|restarted LEVEL` (with `hold-walk FLOOR RATE` \
                                        and `hold-drift PER_SAMPLE`), each once"
                                .into())
                        }
                    };
                }
                self.decisions.push(Decision {
                    name: name.to_string(),
                    integration,
                    threshold,
                    walk,
                    typical,
                    cusum,
                    hold,
                });
            }
            _ => return Err(
                "expected `model`, `residuals`, `healthy`, `crossing`, `start-up`, `estimator`, \
                            `param`, `noise` or `arr` with their fields"
                    .into(),
            ),
        }
        Ok(())
    }

    /// The calibration, where no line is missing.
    fn finish(self) -> Result<Calibration, String> {
        let missing = |what: &str| format!("no `{what}` line");
        let (model, hash) = self.model.ok_or_else(|| missing("model"))?;
        Ok(Calibration {
            model,
            hash,
            residuals: self.residuals.ok_or_else(|| missing("residuals"))?,
            healthy: self.healthy.ok_or_else(|| missing("healthy"))?,
            crossing: self.crossing.ok_or_else(|| missing("crossing"))?,
            start_up: self.start_up,
            estimator: self.estimator.ok_or_else(|| missing("estimator"))?,
            params: self.params,
            noise: self.noise,
            decisions: self.decisions,
            combined: self.combined,
            ranges: self.ranges,
        })
    }
}

/// A line's words: quoted names (with `\"` and `\\`) or runs without spaces.
fn words(line: &str) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut chars = line.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
        } else if c == '"' {
            chars.next();
            let mut word = String::new();
            loop {
                match chars.next() {
                    Some('"') => break,
                    Some('\\') => match chars.next() {
                        Some(e @ ('"' | '\\')) => word.push(e),
                        _ => return Err("expected `\\\"` or `\\\\` after `\\`".into()),
                    },
                    Some(c) => word.push(c),
                    None => return Err("a quoted name is not closed".into()),
                }
            }
            out.push(word);
        } else {
            let mut word = String::new();
            while let Some(&c) = chars.peek() {
                if c.is_whitespace() {
                    break;
                }
                word.push(c);
                chars.next();
            }
            out.push(word);
        }
    }
    Ok(out)
}

/// A finite number.
fn finite(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{s}`: expected a finite number")),
    }
}

/// A number at least 0.
fn non_negative(s: &str) -> Result<f64, String> {
    finite(s)
        .ok()
        .filter(|x| *x >= 0.0)
        .ok_or_else(|| format!("`{s}`: expected a number at least 0"))
}

/// A number above 0.
fn positive(s: &str) -> Result<f64, String> {
    finite(s)
        .ok()
        .filter(|x| *x > 0.0)
        .ok_or_else(|| format!("`{s}`: expected a number above 0"))
}

/// A count of samples, at least 1.
fn count(s: &str) -> Result<usize, String> {
    s.parse::<usize>()
        .ok()
        .filter(|n| *n > 0)
        .ok_or_else(|| format!("`{s}`: expected a count of samples"))
}

/// Why a kept calibration does not apply to a model, its residuals or a record.
#[derive(Clone, Debug, PartialEq)]
pub enum Mismatch {
    /// The model's text is not the one calibrated (named as it was then).
    Model(String),
    /// The residuals were chosen and realised otherwise (kept, asked).
    Residuals((String, String), (String, String)),
    /// The calibration's step is not the record's (kept, record's), in seconds.
    Step(f64, f64),
    /// The parameters are not the model's (kept, model's).
    Parameters(Vec<String>, Vec<String>),
    /// The residuals are not the model's (kept, model's).
    Arrs(Vec<String>, Vec<String>),
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Mismatch::Model(was) => write!(
                f,
                "made for another model ({was} as it was then): the model's text differs"
            ),
            Mismatch::Residuals(kept, asked) => write!(
                f,
                "made with residuals `{}` realised `{}`, not `{}` `{}`",
                kept.0, kept.1, asked.0, asked.1
            ),
            Mismatch::Step(kept, record) => write!(
                f,
                "made on a record of step {kept} s, not the record's {record} s"
            ),
            Mismatch::Parameters(kept, model) => write!(
                f,
                "its parameters are {}, the model's {}",
                kept.join(", "),
                model.join(", ")
            ),
            Mismatch::Arrs(kept, model) => write!(
                f,
                "its residuals are {}, the model's {}",
                kept.join(", "),
                model.join(", ")
            ),
        }
    }
}

impl Calibration {
    /// Whether this calibration is for the model of text `text` (without a byte-order mark),
    /// its `residuals` (as spelled), its parameters and ARRs (by name) and a record of step
    /// `step`: a calibration is for the model it was made on, and for nothing else.
    pub fn applies(
        &self,
        text: &[u8],
        residuals: (&str, &str),
        params: &[&str],
        arrs: &[&str],
        step: f64,
    ) -> Result<(), Mismatch> {
        if fnv1a(text) != self.hash {
            return Err(Mismatch::Model(self.model.clone()));
        }
        if (self.residuals.0.as_str(), self.residuals.1.as_str()) != residuals {
            return Err(Mismatch::Residuals(
                self.residuals.clone(),
                (residuals.0.to_string(), residuals.1.to_string()),
            ));
        }
        let made = self.healthy.2;
        if (made - step).abs() > crate::step::STEP_TOLERANCE * step {
            return Err(Mismatch::Step(made, step));
        }
        let owned = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let kept: Vec<&str> = self.params.iter().map(|(n, _)| n.as_str()).collect();
        if kept != params {
            return Err(Mismatch::Parameters(owned(&kept), owned(params)));
        }
        let decided: Vec<&str> = self.decisions.iter().map(|d| d.name.as_str()).collect();
        if decided != arrs {
            return Err(Mismatch::Arrs(owned(&decided), owned(arrs)));
        }
        Ok(())
    }

    /// What tells where a record is singular, where the calibration read it.
    pub fn conditioning(&self) -> Option<Conditioning> {
        (!self.noise.is_empty()).then(|| Conditioning {
            deviations: self.noise.iter().map(|(_, d)| *d).collect(),
            typical: self.decisions.iter().map(|d| d.typical).collect(),
            start_up: self.start_up,
        })
    }

    /// The kept parameter values, in the model's order.
    pub fn values(&self) -> Vec<f64> {
        self.params.iter().map(|(_, v)| *v).collect()
    }

    /// Each raw signal's range of [`Calibration::ranges`], for the signals `names` (the
    /// program's raw signals, in order): `None` for one the file does not give.
    pub fn ranges_for(&self, names: &[&str]) -> Vec<Option<Range>> {
        (names.iter())
            .map(|n| self.ranges.iter().find(|(s, _)| s == n).map(|(_, r)| *r))
            .collect()
    }

    /// The combinations of [`Calibration::combined`] by the parameters' places (a name
    /// that is not a parameter of the calibration is left out).
    pub fn combined_places(&self) -> Vec<Vec<usize>> {
        let place = |n: &String| self.params.iter().position(|(p, _)| p == n);
        (self.combined.iter())
            .map(|names| names.iter().filter_map(place).collect::<Vec<_>>())
            .filter(|c| c.len() > 1)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Calibration {
        Calibration {
            model: "models/a \"b\".bg".into(),
            hash: fnv1a(b"R r = 1"),
            residuals: ("per-sensor".into(), "lowest".into()),
            healthy: ("h.csv".into(), 2001, 1e-3),
            crossing: 1e-3,
            start_up: Some(0.994),
            estimator: Estimator::SavitzkyGolay {
                window: 201,
                degree: 3,
            },
            params: vec![("ke".into(), 0.508_269_488_618_310_7), ("N".into(), 5.0)],
            noise: vec![("y1".into(), 1e-4), ("U0".into(), 0.0)],
            combined: vec![vec!["ke".into(), "N".into()]],
            ranges: vec![(
                "y1".into(),
                Range {
                    least: -4.0,
                    most: 12.5,
                },
            )],
            decisions: vec![
                Decision {
                    name: "ARR1".into(),
                    integration: Some(Integration::Start),
                    threshold: Some(6.59),
                    walk: Some(Walk {
                        floor: 1.2e-6,
                        rate: 3.4e-11,
                        drift: 2.5e-9,
                    }),
                    typical: None,
                    cusum: None,
                    hold: None,
                },
                Decision {
                    name: "ARR2".into(),
                    integration: None,
                    threshold: None,
                    walk: None,
                    typical: Some(2.5e-5),
                    cusum: Some(CusumLevels {
                        sigma: 1.5e-5,
                        drift: 0.5,
                        level: 21.25,
                    }),
                    hold: None,
                },
                Decision {
                    name: "ARR3".into(),
                    integration: Some(Integration::Window(250)),
                    threshold: Some(0.015),
                    walk: None,
                    typical: None,
                    cusum: None,
                    hold: Some(Hold {
                        integration: Integration::Start,
                        anchored: true,
                        level: 4.25,
                        walk: Some(Walk {
                            floor: 1e-6,
                            rate: 2e-11,
                            drift: 3e-9,
                        }),
                    }),
                },
            ],
        }
    }

    #[test]
    fn a_calibration_reads_back_as_written() {
        let c = sample();
        let text = c.write();
        assert_eq!(Calibration::parse(&text), Ok(c));
    }

    #[test]
    fn a_bad_line_is_refused_with_its_number_and_what_was_expected() {
        let text = sample().write().replace("arr ARR3 250", "arr ARR3 0");
        let e = Calibration::parse(&text).unwrap_err();
        assert!(
            e.starts_with("line 17: `arr ARR3 0 0.015 hold start"),
            "{e}"
        );
        assert!(e.contains("expected a count of samples"), "{e}");
        let text = sample().write().replace("anchored", "stuck");
        let e = Calibration::parse(&text).unwrap_err();
        assert!(
            e.contains("`stuck`: expected `anchored` or `restarted`"),
            "{e}"
        );
        let text = sample().write().replace(" hold start anchored 4.25", "");
        let e = Calibration::parse(&text).unwrap_err();
        assert!(e.contains("`hold-walk` before `hold`"), "{e}");
        let e = Calibration::parse("model x").unwrap_err();
        assert!(e.contains("expected `bgc-calibration 1`"), "{e}");
        let text = sample().write().replace("crossing 0.001\n", "");
        assert_eq!(Calibration::parse(&text), Err("no `crossing` line".into()));
        let text = sample().write().replace("param N 5.0", "param N inf");
        assert!(Calibration::parse(&text)
            .unwrap_err()
            .contains("a finite number"));
    }

    #[test]
    fn the_hash_tells_texts_apart() {
        assert_ne!(fnv1a(b"param K = 1"), fnv1a(b"param K = 2"));
        // The reference values of FNV-1a 64.
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}
