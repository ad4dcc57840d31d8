//! A simulation scenario as written: how long, what drives the inputs, which faults happen when,
//! which noise the sensors add. One statement per line; the syntax is in `docs/simulation.md`.
//!
//! Names are not resolved here: the scenario is read on its own, then checked against a model
//! when a simulation is built from both (`sim/plant.rs`).

use bondgraph_core::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use bondgraph_core::{parse_expr, AstExpr, Ident};

/// Which integration method runs the plant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// Dormand–Prince 5(4), explicit and adaptive: for models that are not stiff.
    DormandPrince,
    /// Kværnø's ESDIRK 7-stage method of order 5 (4), implicit and adaptive: for stiff models.
    Implicit,
    /// Dormand–Prince, switching to the implicit method when the explicit one reports
    /// stiffness.
    Auto,
}

/// How a fault enters over time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Onset {
    /// All at once at this time.
    Abrupt(f64),
    /// Growing linearly from nothing at the first time to its full size at the second.
    Drift(f64, f64),
}

impl Onset {
    /// How much of the fault is present at `t`, from 0 to 1.
    pub(crate) fn fraction(self, t: f64) -> f64 {
        match self {
            Onset::Abrupt(at) => f64::from(u8::from(t >= at)),
            Onset::Drift(from, to) if to > from => ((t - from) / (to - from)).clamp(0.0, 1.0),
            Onset::Drift(from, _) => f64::from(u8::from(t >= from)),
        }
    }

    /// The times at which the fault's course has a kink: where the integration restarts.
    pub(crate) fn breaks(self) -> Vec<f64> {
        match self {
            Onset::Abrupt(at) => vec![at],
            Onset::Drift(from, to) => vec![from, to],
        }
    }
}

/// Whether a signal fault adds to the signal or scales it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FaultMode {
    /// `signal + size`.
    Additive,
    /// `signal * size`: a gain (1 leaves the signal as it is).
    Multiplicative,
}

/// What a fault changes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum FaultTarget {
    /// A parameter of the plant takes a new value.
    Parameter(Ident),
    /// A measured signal as the sensor reports it.
    Sensor(Ident, FaultMode),
    /// An input as the plant receives it; the record keeps the commanded value.
    Actuator(Ident, FaultMode),
}

/// One fault of the scenario.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Fault {
    /// What it changes.
    pub target: FaultTarget,
    /// Its full size: the parameter's new value, the added offset, or the gain. A constant
    /// expression, which may read the model's parameters (their nominal values).
    pub size: AstExpr,
    /// When it comes.
    pub onset: Onset,
    /// The whole statement.
    pub span: Span,
}

/// A named value of the scenario with its span: `initial`, `noise`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Setting {
    /// The name it applies to.
    pub name: Ident,
    /// Its value.
    pub value: f64,
}

/// How a recorded signal is quantised as its sensor reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Quantiser {
    /// Read to the nearest multiple of this resolution (a converter's least step, an
    /// absolute encoder's angle): `resolution y 0.01`.
    Resolution(f64),
    /// A shaft's speed as an incremental encoder of this many counts per revolution gives
    /// it: the speed integrated to an angle, counted, and the counts' difference over one
    /// sample taken as the speed: `encoder y 4096`.
    Encoder(f64),
}

/// A quantised signal of the scenario: its name and its quantiser.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Quantising {
    /// The recorded signal quantised.
    pub name: Ident,
    /// How.
    pub how: Quantiser,
}

/// A scenario, read but not yet checked against a model.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// How long to simulate, in seconds.
    pub duration: f64,
    /// The step of the written samples, in seconds.
    pub output_step: f64,
    /// The integration method.
    pub solver: Solver,
    /// The solver's relative tolerance (the absolute one is a thousandth of it).
    pub tolerance: f64,
    /// The seed of the measurement noise.
    pub seed: u64,
    /// Named signals (`let r = ...`), in order: each may read those before it.
    pub(crate) lets: Vec<(Ident, AstExpr)>,
    /// What drives each input (`input U0 = ...`): an expression of `t`, `let`s, parameters,
    /// measured signals and their derivatives (a closed loop).
    pub(crate) inputs: Vec<(Ident, AstExpr)>,
    /// The faults.
    pub(crate) faults: Vec<Fault>,
    /// White measurement noise: the standard deviation on each named measured signal or input.
    pub(crate) noise: Vec<Setting>,
    /// Initial values of states (others start at 0).
    pub(crate) initial: Vec<Setting>,
    /// Signals read by quantising sensors, after their noise.
    pub(crate) quantised: Vec<Quantising>,
}

impl Scenario {
    /// When each fault starts (an abrupt one's time, a drift's first), in statement order:
    /// what a plot marks.
    pub fn fault_onsets(&self) -> Vec<f64> {
        (self.faults.iter())
            .map(|f| match f.onset {
                Onset::Abrupt(at) | Onset::Drift(at, _) => at,
            })
            .collect()
    }

    /// What is wrong with its duration and output step, once something other than its text
    /// set them (the command line's `--duration` and `--step`): each as a sentence.
    pub fn check_settings(&self) -> Vec<String> {
        let mut d = Diagnostics::default();
        check_times(self, &mut d, 0);
        d.iter().map(|d| d.message.clone()).collect()
    }
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            duration: 10.0,
            output_step: 1e-3,
            solver: Solver::Auto,
            tolerance: 1e-8,
            seed: 0,
            lets: Vec::new(),
            inputs: Vec::new(),
            faults: Vec::new(),
            noise: Vec::new(),
            initial: Vec::new(),
            quantised: Vec::new(),
        }
    }
}

/// Most counts per revolution an `encoder` statement takes: a 32-bit encoder's.
const MAX_COUNTS: f64 = 4_294_967_296.0;

/// Longest simulation, in output samples: a bound on memory and time for a mistyped duration.
pub const MAX_SAMPLES: f64 = 1e7;

/// Reads a scenario; `None` with the diagnostics when any statement is wrong.
pub fn parse_scenario(text: &str) -> (Option<Scenario>, Diagnostics) {
    let mut scenario = Scenario::default();
    let mut diagnostics = Diagnostics::default();
    let mut offset = 0;
    for raw in text.split_inclusive('\n') {
        let line = raw.split('#').next().unwrap_or("");
        let trimmed = line.trim_end();
        let start = offset + (trimmed.len() - trimmed.trim_start().len());
        let content = trimmed.trim_start();
        if !content.is_empty() {
            if let Err(d) = statement(&mut scenario, content, start) {
                d.into_iter().for_each(|d| diagnostics.push(d));
            }
        }
        offset += raw.len();
    }
    check_times(&scenario, &mut diagnostics, text.len());
    let ok = !diagnostics.has_errors();
    (ok.then_some(scenario), diagnostics)
}

fn check_times(s: &Scenario, diagnostics: &mut Diagnostics, end: usize) {
    let whole = Span::new(0, end);
    if !(s.duration.is_finite() && s.duration > 0.0) {
        diagnostics.push(Diagnostic::error(
            Code::BadValue,
            whole,
            format!(
                "the duration must be a positive number of seconds, not {}",
                s.duration
            ),
        ));
    }
    if !(s.output_step.is_finite() && s.output_step > 0.0) {
        diagnostics.push(Diagnostic::error(
            Code::BadValue,
            whole,
            format!(
                "the output step must be a positive number of seconds, not {}",
                s.output_step
            ),
        ));
    } else if s.duration.is_finite() && s.output_step > s.duration {
        diagnostics.push(Diagnostic::error(
            Code::BadValue,
            whole,
            format!(
                "the output step ({} s) is longer than the duration ({} s): no sample after the first",
                s.output_step, s.duration
            ),
        ));
    } else if s.duration / s.output_step > MAX_SAMPLES {
        diagnostics.push(Diagnostic::error(
            Code::TooLarge,
            whole,
            format!(
                "{} s at a step of {} s is more than {MAX_SAMPLES:e} samples",
                s.duration, s.output_step
            ),
        ));
    }
}

type Parsed = Result<(), Vec<Diagnostic>>;

/// One statement, `text` starting at byte `at` of the scenario.
fn statement(s: &mut Scenario, text: &str, at: usize) -> Parsed {
    let (word, rest, rest_at) = split_word(text, at);
    match word {
        "duration" => s.duration = number(rest, rest_at)?,
        "step" => s.output_step = number(rest, rest_at)?,
        "tolerance" => s.tolerance = positive(rest, rest_at)?,
        "seed" => {
            s.seed = rest
                .trim()
                .parse()
                .map_err(|_| one(rest_at, rest, "expected a whole number (the noise's seed)"))?;
        }
        "solver" => {
            s.solver = match rest.trim() {
                "dopri5" => Solver::DormandPrince,
                "implicit" => Solver::Implicit,
                "auto" => Solver::Auto,
                _ => return Err(one(rest_at, rest, "expected `dopri5`, `implicit` or `auto`")),
            };
        }
        "let" => s.lets.push(definition(rest, rest_at)?),
        "input" => s.inputs.push(definition(rest, rest_at)?),
        "noise" => {
            let (name, value, value_at) = split_word(rest, rest_at);
            let name = ident(name, rest_at, rest)?;
            s.noise.push(Setting {
                name,
                value: positive(value, value_at)?,
            });
        }
        "resolution" | "encoder" => {
            let (name, value, value_at) = split_word(rest, rest_at);
            let name = ident(name, rest_at, rest)?;
            let how = if word == "encoder" {
                let counts = positive(value, value_at)?;
                if counts.fract() != 0.0 || counts > MAX_COUNTS {
                    return Err(one(
                        value_at,
                        value,
                        "expected a whole number of counts per revolution (at most 2^32)",
                    ));
                }
                Quantiser::Encoder(counts)
            } else {
                Quantiser::Resolution(positive(value, value_at)?)
            };
            s.quantised.push(Quantising { name, how });
        }
        "initial" => {
            let (name, value) = definition(rest, rest_at)?;
            let value = match value {
                AstExpr::Num(v) => v,
                AstExpr::Neg(inner) => match *inner {
                    AstExpr::Num(v) => -v,
                    _ => return Err(one(rest_at, rest, "expected `STATE = NUMBER`")),
                },
                _ => return Err(one(rest_at, rest, "expected `STATE = NUMBER`")),
            };
            s.initial.push(Setting { name, value });
        }
        "fault" => s.faults.push(fault(rest, rest_at, Span::new(at, at + text.len()))?),
        _ => {
            return Err(one(
                at,
                word,
                "expected a statement: `duration`, `step`, `solver`, `tolerance`, `seed`, `let`, `input`, `fault`, `noise`, `resolution`, `encoder` or `initial`",
            ))
        }
    }
    Ok(())
}

/// The first word of `text` (which starts at byte `at`), the rest, and where the rest starts.
fn split_word(text: &str, at: usize) -> (&str, &str, usize) {
    let text_start = text.len() - text.trim_start().len();
    let body = text.trim_start();
    let end = body.find(char::is_whitespace).unwrap_or(body.len());
    let (word, rest) = body.split_at(end);
    (word, rest, at + text_start + end)
}

/// An error over `text`, which starts at byte `at`.
fn one(at: usize, text: &str, expected: &str) -> Vec<Diagnostic> {
    let lead = text.len() - text.trim_start().len();
    let shown = text.trim();
    // Nothing found: a point at the end of the line, which may be the end of the text.
    let span = Span::new(at + lead, at + lead + shown.len());
    let found = if shown.is_empty() {
        "the end of the line".to_string()
    } else {
        format!("`{shown}`")
    };
    vec![
        Diagnostic::error(Code::Syntax, span, format!("{expected}, found {found}"))
            .with_label(expected.to_string()),
    ]
}

fn number(text: &str, at: usize) -> Result<f64, Vec<Diagnostic>> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| one(at, text, "expected a number"))
}

fn positive(text: &str, at: usize) -> Result<f64, Vec<Diagnostic>> {
    number(text, at).and_then(|v| {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(one(at, text, "expected a positive number"))
        }
    })
}

fn ident(name: &str, at: usize, context: &str) -> Result<Ident, Vec<Diagnostic>> {
    let lead = context.len() - context.trim_start().len();
    let valid = name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !valid {
        return Err(one(at, context, "expected a name"));
    }
    Ok(Ident {
        name: name.to_string(),
        span: Span::new(at + lead, at + lead + name.len()),
    })
}

/// `NAME = EXPR`.
fn definition(text: &str, at: usize) -> Result<(Ident, AstExpr), Vec<Diagnostic>> {
    let Some(eq) = text.find('=') else {
        return Err(one(at, text, "expected `NAME = EXPRESSION`"));
    };
    let name = ident(text[..eq].trim(), at, &text[..eq])?;
    let expr = parse_expr(&text[eq + 1..], at + eq + 1)?;
    Ok((name, expr))
}

/// `fault TARGET ... at T` or `... from T1 to T2`.
fn fault(text: &str, at: usize, span: Span) -> Result<Fault, Vec<Diagnostic>> {
    let (body, onset) = onset(text, at)?;
    let (word, rest, rest_at) = split_word(body, at);
    let signal =
        |rest: &str, rest_at: usize| -> Result<(Ident, FaultMode, AstExpr), Vec<Diagnostic>> {
            let Some(op) = rest.find(['+', '*']) else {
                return Err(one(
                    rest_at,
                    rest,
                    "expected `NAME + SIZE` or `NAME * GAIN`",
                ));
            };
            let name = ident(rest[..op].trim(), rest_at, &rest[..op])?;
            let mode = if rest[op..].starts_with('+') {
                FaultMode::Additive
            } else {
                FaultMode::Multiplicative
            };
            let size = parse_expr(&rest[op + 1..], rest_at + op + 1)?;
            Ok((name, mode, size))
        };
    let (target, size) = match word {
        "sensor" => {
            let (name, mode, size) = signal(rest, rest_at)?;
            (FaultTarget::Sensor(name, mode), size)
        }
        "actuator" => {
            let (name, mode, size) = signal(rest, rest_at)?;
            (FaultTarget::Actuator(name, mode), size)
        }
        _ => {
            let (name, size) = definition(body, at)?;
            (FaultTarget::Parameter(name), size)
        }
    };
    Ok(Fault {
        target,
        size,
        onset,
        span,
    })
}

/// Splits the trailing `at T` or `from T1 to T2` off a fault.
fn onset(text: &str, at: usize) -> Result<(&str, Onset), Vec<Diagnostic>> {
    let words = |key: &str| text.rfind(&format!(" {key} "));
    if let Some(k) = words("at").filter(|&k| words("from").is_none_or(|f| k > f)) {
        let tail = &text[k + 4..];
        return Ok((&text[..k], Onset::Abrupt(number(tail, at + k + 4)?)));
    }
    if let Some(f) = words("from") {
        let tail = &text[f + 6..];
        let Some(to) = tail.find(" to ") else {
            return Err(one(at + f + 6, tail, "expected `from START to END`"));
        };
        let start = number(&tail[..to], at + f + 6)?;
        let end = number(&tail[to + 4..], at + f + 6 + to + 4)?;
        if end < start {
            return Err(one(
                at + f + 6,
                tail,
                "expected an end no earlier than the start",
            ));
        }
        return Ok((&text[..f], Onset::Drift(start, end)));
    }
    Err(one(
        at + text.len(),
        "",
        "expected `at TIME` or `from START to END` at the end of the fault",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoders_and_resolutions_are_read_and_bad_counts_refused() {
        let (s, d) = parse_scenario("encoder y1 4096\nresolution y2 0.01\n");
        assert!(!d.has_errors(), "{d:?}");
        let s = s.expect("scenario");
        assert_eq!(s.quantised[0].name.name, "y1");
        assert_eq!(s.quantised[0].how, Quantiser::Encoder(4096.0));
        assert_eq!(s.quantised[1].how, Quantiser::Resolution(0.01));
        for bad in ["encoder y1 40.5\n", "encoder y1 0\n", "resolution y1 -1\n"] {
            let (s, d) = parse_scenario(bad);
            assert!(s.is_none() && d.has_errors(), "{bad}");
        }
    }

    #[test]
    fn a_scenario_reads_every_statement() {
        let text = "duration 25   # seconds\nstep 0.001\nsolver implicit\nseed 7\n\
                    let r = 10*(1 - exp(-t))\ninput U0 = 1.25*(r - y1) + 0.5*(der(r) - der(y1))\n\
                    fault j0 = 3*j0 at 10\nfault Re = 1.5*Re from 5 to 15\n\
                    fault sensor y1 + 0.02 at 8\nfault actuator U0 * 0.9 at 12\n\
                    noise y1 0.001\ninitial p_Je = -0.5\n";
        let (s, d) = parse_scenario(text);
        assert!(d.is_empty(), "{d:?}");
        let s = s.expect("valid");
        assert_eq!((s.duration, s.output_step, s.seed), (25.0, 0.001, 7));
        assert_eq!(s.solver, Solver::Implicit);
        assert_eq!((s.lets.len(), s.inputs.len(), s.faults.len()), (1, 1, 4));
        assert_eq!(s.faults[1].onset, Onset::Drift(5.0, 15.0));
        assert!(matches!(
            &s.faults[3].target,
            FaultTarget::Actuator(name, FaultMode::Multiplicative) if name.name == "U0"
        ));
        assert_eq!(s.initial[0].value, -0.5);
        assert_eq!(s.noise[0].name.name, "y1");
        let input = &s.inputs[0].0;
        assert_eq!(&text[input.span.start..input.span.end], "U0");
    }

    #[test]
    fn mistakes_are_reported_where_they_are() {
        let text = "duration soon\nfault j0 = 3*j0\ninput U0 = 1 +\nwhatever 3\n";
        let (s, d) = parse_scenario(text);
        assert!(s.is_none());
        let found: Vec<(&str, String)> = d
            .iter()
            .map(|d| (&text[d.span.start..d.span.end], d.message.clone()))
            .collect();
        assert_eq!(found.len(), 4, "{found:?}");
        assert_eq!(found[0].0, "soon");
        assert!(found[1].1.contains("at TIME"), "{found:?}");
        assert!(found[3].1.starts_with("expected a statement"), "{found:?}");
        assert_eq!(found[3].0, "whatever");
    }

    #[test]
    fn onsets_grow_as_stated() {
        assert_eq!(Onset::Abrupt(1.0).fraction(0.5), 0.0);
        assert_eq!(Onset::Abrupt(1.0).fraction(1.0), 1.0);
        assert_eq!(Onset::Drift(2.0, 4.0).fraction(3.0), 0.5);
        assert_eq!(Onset::Drift(2.0, 4.0).fraction(9.0), 1.0);
    }
}
