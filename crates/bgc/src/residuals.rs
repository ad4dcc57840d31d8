//! `bgc residuals`: the ARRs evaluated over recorded samples, with thresholds, alarms and the
//! candidate components.
//!
//! The residuals are computed as the generated `ResidualGenerator` computes them, with the
//! same runtime estimators in the same order (the product's [`Readings`]): a Savitzky–Golay
//! fit per raw signal, each signal's integral through [`EstimatedIntegral`], each nonlinear
//! integral by the trapezoidal rule at the estimates' instant. The two agree to rounding.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use bondgraph::{EstimatedIntegral, SavitzkyGolay, Threshold, Trapezoid};
use bondgraph_core::{
    Compiled, Derive, Expr, Handle, Node, Quantity, Readings, Signal, Symbol, Tape,
};

use crate::cli::{self, Failure};

/// What `bgc residuals` takes.
#[derive(clap::Args, Debug)]
pub struct ResidualArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// The recorded samples: CSV with a header, a time column `t` at a uniform step, and one
    /// column per input and measured signal the ARRs read, named as in the model.
    #[arg(value_name = "DATA")]
    data: PathBuf,
    /// Samples in the Savitzky–Golay window (odd).
    #[arg(long, value_name = "N", default_value_t = 11)]
    window: usize,
    /// Degree of the Savitzky–Golay polynomial.
    #[arg(long, value_name = "D", default_value_t = 3)]
    degree: u32,
    /// A fixed threshold on |residual|, as `ARR=LEVEL` (e.g. `ARR1=0.05`); repeat for more.
    /// Residuals without one raise no alarm.
    #[arg(long = "threshold", value_name = "ARR=LEVEL")]
    thresholds: Vec<String>,
    /// Consecutive samples above (below) a threshold that raise (clear) its alarm.
    #[arg(long, value_name = "N", default_value_t = 1)]
    debounce: u32,
    /// Write the CSV to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
}

/// Runs `bgc residuals`.
pub fn run(args: ResidualArgs) -> Result<(), Failure> {
    let c = cli::compile(&args.model, Derive::Everything, None)?;
    if c.has_errors() || c.arrs.is_empty() {
        eprintln!("error: {}: no ARRs to evaluate", c.file_name);
        return Err(Failure::Invalid);
    }
    let readings = c.readings();
    let names: Vec<String> = readings
        .raw
        .iter()
        .map(|&(s, _)| signal_name(&c, s))
        .collect();
    let data_name = args.data.display().to_string();
    let (_, bytes) = cli::read(&args.data)?;
    let data = Data::read(&bytes, &names, args.window).map_err(|e| {
        eprintln!("error: {data_name}: {e}");
        Failure::Invalid
    })?;
    let levels = thresholds(&c, &args.thresholds)?;
    let params: Vec<f64> = c.parameters.iter().map(|(_, p)| p.value).collect();
    let mut generator = Generator::new(&c, &readings, &params, data.step, args.window, args.degree)
        .map_err(|e| {
            eprintln!("error: {e}");
            Failure::Usage
        })?;
    let mut alarms: Vec<Option<Threshold>> = levels
        .iter()
        .map(|l| l.map(|l| Threshold::new(l, args.debounce)))
        .collect();
    let mut out = header(&c);
    let rows: Vec<(&str, Vec<bool>)> = c
        .components
        .iter()
        .map(|(_, comp)| (comp.name.as_str(), comp.signature(c.arrs.len())))
        .collect();
    let mut raw = vec![0.0; names.len()];
    for (k, &t) in data.time.iter().enumerate() {
        for (v, column) in raw.iter_mut().zip(&data.columns) {
            *v = column[k];
        }
        let Some((at, residuals)) = generator.push(t, &raw) else {
            continue;
        };
        let on: Vec<bool> = residuals
            .iter()
            .zip(&mut alarms)
            .map(|(&r, a)| a.as_mut().is_some_and(|a| a.update(r)))
            .collect();
        let candidates = bondgraph::candidates(rows.iter().map(|(n, s)| (*n, s.as_slice())), &on);
        row(&mut out, at, &residuals, &levels, &on, &candidates);
    }
    cli::write(args.output.as_deref(), &out)
}

fn signal_name(c: &Compiled, s: Signal) -> String {
    match s {
        Signal::Input(u) => c.inputs[u].name.clone(),
        Signal::Sensor(h) => c.sensors[h].name.clone(),
    }
}

/// Each ARR's fixed threshold, from `ARR=LEVEL` arguments.
fn thresholds(c: &Compiled, given: &[String]) -> Result<Vec<Option<f64>>, Failure> {
    let mut levels = vec![None; c.arrs.len()];
    for g in given {
        let parsed = g.split_once('=').and_then(|(name, level)| {
            let k = c.arrs.iter().position(|a| a.name == name.trim())?;
            let level: f64 = level.trim().parse().ok().filter(|l: &f64| *l >= 0.0)?;
            Some((k, level))
        });
        match parsed {
            Some((k, level)) => levels[k] = Some(level),
            None => {
                let names: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
                eprintln!(
                    "error: --threshold `{g}`: expected ARR=LEVEL with ARR one of {} and LEVEL a non-negative number",
                    names.join(", ")
                );
                return Err(Failure::Usage);
            }
        }
    }
    Ok(levels)
}

fn header(c: &Compiled) -> String {
    let mut h = String::from("t");
    for a in &c.arrs {
        let _ = write!(h, ",{}", a.name);
    }
    for a in &c.arrs {
        let _ = write!(h, ",threshold_{}", a.name);
    }
    for a in &c.arrs {
        let _ = write!(h, ",alarm_{}", a.name);
    }
    h.push_str(",candidates\n");
    h
}

fn row(
    out: &mut String,
    t: f64,
    residuals: &[f64],
    levels: &[Option<f64>],
    on: &[bool],
    candidates: &[&str],
) {
    let _ = write!(out, "{t}");
    for r in residuals {
        let _ = write!(out, ",{r}");
    }
    for l in levels {
        match l {
            Some(l) => {
                let _ = write!(out, ",{l}");
            }
            None => out.push(','),
        }
    }
    for &a in on {
        out.push_str(if a { ",1" } else { ",0" });
    }
    let _ = writeln!(out, ",{}", candidates.join(" "));
}

/// Recorded samples: the time and the columns asked for, checked.
pub struct Data {
    /// The time of each row.
    pub time: Vec<f64>,
    /// The step between rows.
    pub step: f64,
    /// One column per name asked for, in that order.
    pub columns: Vec<Vec<f64>>,
}

/// Relative tolerance on the time step: rows must be this regular.
const STEP_TOLERANCE: f64 = 1e-6;

impl Data {
    /// Reads CSV `bytes`, keeping `names` (and `t`); needs at least `window` rows.
    pub fn read(bytes: &[u8], names: &[String], window: usize) -> Result<Data, String> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(bytes);
        let header = reader
            .headers()
            .map_err(|e| format!("cannot read the header: {e}"))?
            .clone();
        let find = |name: &str| header.iter().position(|h| h == name);
        let t = find("t").ok_or("no time column: the header needs a column named `t`")?;
        let mut at = Vec::with_capacity(names.len());
        for name in names {
            at.push(find(name).ok_or_else(|| {
                format!(
                    "no column `{name}`: the ARRs read {}; the header has {}",
                    names.join(", "),
                    header.iter().collect::<Vec<_>>().join(", ")
                )
            })?);
        }
        let mut time = Vec::new();
        let mut columns = vec![Vec::new(); names.len()];
        for (k, record) in reader.records().enumerate() {
            // Line numbers as an editor shows them: the header is line 1.
            let line = k + 2;
            let record = record.map_err(|e| format!("line {line}: {e}"))?;
            let value = |i: usize, name: &str| -> Result<f64, String> {
                let text = record.get(i).unwrap_or("");
                text.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        format!("line {line}, column `{name}`: `{text}` is not a finite number")
                    })
            };
            time.push(value(t, "t")?);
            for ((column, &i), name) in columns.iter_mut().zip(&at).zip(names) {
                column.push(value(i, name)?);
            }
        }
        let step = check_time(&time)?;
        if time.len() < window {
            return Err(format!(
                "{} rows: the estimator's window of {window} samples needs at least {window}",
                time.len()
            ));
        }
        Ok(Data {
            time,
            step,
            columns,
        })
    }
}

/// The uniform step of `time`, or the first line where it is not.
fn check_time(time: &[f64]) -> Result<f64, String> {
    let [t0, t1, ..] = time else {
        return Err(format!("{} rows: too few samples", time.len()));
    };
    let step = t1 - t0;
    for (k, pair) in time.windows(2).enumerate() {
        let d = pair[1] - pair[0];
        let line = k + 3;
        if d <= 0.0 {
            return Err(format!(
                "line {line}: time goes from {} to {}: it must increase",
                pair[0], pair[1]
            ));
        }
        if (d - step).abs() > STEP_TOLERANCE * step {
            return Err(format!(
                "line {line}: a step of {d} s where the record's is {step} s: the estimators need a uniform step"
            ));
        }
    }
    Ok(step)
}

/// The residual generator of a compiled model, read at run time: the same estimators, in the
/// same order, as the generated `ResidualGenerator`.
pub struct Generator {
    raw: Vec<(Signal, u32)>,
    estimators: Vec<SavitzkyGolay>,
    integrals: Vec<(usize, EstimatedIntegral<SavitzkyGolay>)>,
    nonlinear: Vec<Trapezoid>,
    /// Where each quantity's value sits in `values`.
    slot: HashMap<Quantity, usize>,
    /// The nonlinear integrands, then each auxiliary derivative, then the ARRs.
    integrands: Tape<Symbol>,
    auxiliaries: Vec<(AuxKey, Tape<Symbol>)>,
    arrs: Tape<Symbol>,
    /// Each `int(..)` node of the ARRs: a combination of signal integrals, or a nonlinear one.
    int_nodes: HashMap<Expr, IntValue>,
    params: Vec<f64>,
    delay: f64,
    values: Vec<f64>,
    scratch: Vec<f64>,
}

/// An auxiliary signal's derivative: which, and its order.
type AuxKey = (Handle<bondgraph_core::Auxiliary>, u32);

enum IntValue {
    Linear(Vec<(f64, Signal)>),
    Nonlinear(usize),
}

impl Generator {
    /// Centred Savitzky–Golay fits of `degree` over `window` samples every `step` seconds.
    pub fn new(
        c: &Compiled,
        readings: &Readings,
        params: &[f64],
        step: f64,
        window: usize,
        degree: u32,
    ) -> Result<Generator, bondgraph::EstimatorError> {
        let fit = |order: u32| SavitzkyGolay::new(order, degree, window, step, true);
        let estimators = readings
            .raw
            .iter()
            .map(|&(_, n)| fit(n))
            .collect::<Result<Vec<_>, _>>()?;
        let integrals = readings
            .integrated
            .iter()
            .map(|s| {
                let k = readings.raw.iter().position(|(r, _)| r == s).unwrap_or(0);
                Ok((k, EstimatedIntegral::new(fit(0)?)))
            })
            .collect::<Result<Vec<_>, bondgraph::EstimatorError>>()?;
        let delay = estimators
            .iter()
            .map(bondgraph::Differentiator::delay)
            .fold(0.0, f64::max);
        let constant = |e: Expr| {
            bondgraph_core::Evaluator::new(&c.exprs, |s| match s {
                Symbol::Parameter(p) => params[p.index()],
                _ => f64::NAN,
            })
            .value(e)
        };
        let mut int_nodes = HashMap::new();
        let roots: Vec<Expr> = c.arrs.iter().map(|a| a.expr).collect();
        let mut all_roots = roots.clone();
        all_roots.extend(
            c.auxiliaries
                .iter()
                .flat_map(|(_, a)| a.derivatives.iter().copied()),
        );
        all_roots.extend(readings.nonlinear.iter().copied());
        c.exprs.visit_reachable(&all_roots, |id, node| {
            if let Node::Int(arg) = node {
                let value = match readings.nonlinear.iter().position(|&e| e == arg) {
                    Some(k) => IntValue::Nonlinear(k),
                    None => IntValue::Linear(
                        c.linear_terms(arg)
                            .unwrap_or_default()
                            .into_iter()
                            .map(|(plus, coefficient, s)| {
                                let v = coefficient.map_or(1.0, constant);
                                (if plus { v } else { -v }, s)
                            })
                            .collect(),
                    ),
                };
                int_nodes.insert(id, value);
            }
        });
        let auxiliaries = c
            .auxiliaries
            .iter()
            .flat_map(|(a, aux)| {
                (0u32..)
                    .zip(&aux.derivatives)
                    .map(move |(n, &e)| ((a, n), e))
            })
            .map(|(key, e)| (key, Tape::new(&c.exprs, &[e])))
            .collect();
        Ok(Generator {
            raw: readings.raw.clone(),
            estimators,
            integrals,
            nonlinear: vec![Trapezoid::new(); readings.nonlinear.len()],
            slot: readings
                .quantities
                .iter()
                .enumerate()
                .map(|(i, &q)| (q, i))
                .collect(),
            integrands: Tape::new(&c.exprs, &readings.nonlinear),
            auxiliaries,
            arrs: Tape::new(&c.exprs, &roots),
            int_nodes,
            params: params.to_vec(),
            delay,
            values: vec![0.0; readings.quantities.len()],
            scratch: Vec::new(),
        })
    }

    /// Takes the raw samples at `t` (in [`Readings::raw`] order) and returns, once the windows
    /// are full, the residuals at `t` minus the estimators' delay, with that instant.
    pub fn push(&mut self, t: f64, raw: &[f64]) -> Option<(f64, Vec<f64>)> {
        let mut ready = true;
        let mut fresh: Vec<Option<f64>> = vec![None; self.raw.len()];
        for (k, (e, &x)) in self.estimators.iter_mut().zip(raw).enumerate() {
            match bondgraph::Differentiator::push(e, x) {
                Some(d) => {
                    let signal = self.raw[k].0;
                    for (n, &v) in (0u32..).zip(d) {
                        if let Some(&i) = self.slot.get(&Quantity::Derivative(signal, n)) {
                            self.values[i] = v;
                        }
                    }
                    fresh[k] = d.first().copied();
                }
                None => ready = false,
            }
        }
        for (k, integral) in &mut self.integrals {
            match integral.push(t, raw[*k], fresh[*k]) {
                Some(v) => {
                    let signal = self.raw[*k].0;
                    if let Some(&i) = self.slot.get(&Quantity::Integral(signal)) {
                        self.values[i] = v;
                    }
                }
                None => ready = false,
            }
        }
        if !ready {
            return None;
        }
        let at = t - self.delay;
        let integrands = self.evaluate_integrands(at);
        for (k, (trapezoid, v)) in self.nonlinear.iter_mut().zip(integrands).enumerate() {
            let value = trapezoid.push(at, v);
            if let Some(&i) = self.slot.get(&Quantity::Nonlinear(k)) {
                self.values[i] = value;
            }
        }
        let mut auxiliary: HashMap<AuxKey, f64> = HashMap::new();
        let mut scratch = std::mem::take(&mut self.scratch);
        for (key, tape) in &self.auxiliaries {
            let v = tape.values(
                |s| self.leaf(s, at, &auxiliary),
                |id| self.integral(id),
                &mut scratch,
            );
            auxiliary.insert(*key, v.first().copied().unwrap_or(f64::NAN));
        }
        let residuals = self.arrs.values(
            |s| self.leaf(s, at, &auxiliary),
            |id| self.integral(id),
            &mut scratch,
        );
        self.scratch = scratch;
        Some((at, residuals))
    }

    fn evaluate_integrands(&mut self, at: f64) -> Vec<f64> {
        if self.nonlinear.is_empty() {
            return Vec::new();
        }
        let none = HashMap::new();
        let mut scratch = std::mem::take(&mut self.scratch);
        let v = self.integrands.values(
            |s| self.leaf(s, at, &none),
            |id| self.integral(id),
            &mut scratch,
        );
        self.scratch = scratch;
        v
    }

    fn leaf(&self, s: Symbol, t: f64, auxiliary: &HashMap<AuxKey, f64>) -> f64 {
        let quantity = |q: Quantity| self.slot.get(&q).map_or(f64::NAN, |&i| self.values[i]);
        match s {
            Symbol::Parameter(p) => self.params.get(p.index()).copied().unwrap_or(f64::NAN),
            Symbol::Input(u, n) => quantity(Quantity::Derivative(Signal::Input(u), n)),
            Symbol::Sensor(h, n) => quantity(Quantity::Derivative(Signal::Sensor(h), n)),
            Symbol::Auxiliary(a, n) => auxiliary.get(&(a, n)).copied().unwrap_or(f64::NAN),
            Symbol::Time => t,
            Symbol::State(_) => f64::NAN,
        }
    }

    fn integral(&self, id: Expr) -> f64 {
        let quantity = |q: Quantity| self.slot.get(&q).map_or(f64::NAN, |&i| self.values[i]);
        match self.int_nodes.get(&id) {
            Some(IntValue::Nonlinear(k)) => quantity(Quantity::Nonlinear(*k)),
            Some(IntValue::Linear(terms)) => terms
                .iter()
                .map(|&(c, s)| c * quantity(Quantity::Integral(s)))
                .sum(),
            None => f64::NAN,
        }
    }
}
