//! `bgc residuals`: the ARRs evaluated over recorded samples, with thresholds, alarms and the
//! candidate components.
//!
//! The residuals are computed as the generated `ResidualGenerator` computes them, with the
//! same runtime estimators in the same order (the product's [`Readings`]): a Savitzky–Golay
//! fit per raw signal, each signal's trapezoidal integral through a fit of its own, each
//! nonlinear integral by the trapezoidal rule at the estimates' instant. The two agree to
//! rounding.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use bondgraph::{Differentiator, Episode, Reference, SavitzkyGolay, Threshold, Trapezoid};
use bondgraph_core::{
    Arr, Compiled, Derive, Expr, ExprId, Handle, Node, Pool, Quantity, Readings, Realisation,
    Realise, Signal, Symbol, Tape,
};

use crate::calibrate::{self, Walk};
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
    /// Samples in the Savitzky–Golay window (odd) [default: with `--calibrate`, the longest
    /// of 11, 21, 51, 101, 201 and 501 samples (at most a tenth of the healthy record) up
    /// to which no residual's RMS on the healthy record grows; else 11].
    #[arg(long, value_name = "N")]
    window: Option<usize>,
    /// Residuals realised by integration (`integrated` in the model's output) are the
    /// relation's integral over the last N samples, or from the record's first estimate
    /// (`start`): a fault that shows only while a signal moves then leaves them offset for
    /// good, but the noise they integrate grows with the record [default: with
    /// `--calibrate`, for each residual, the one of 250, 1000, 2500, 10000 and 25000
    /// samples (at most a twentieth of the healthy record), or from the start where its
    /// noise there is white plus a random walk, with the largest ratio of its length to its
    /// noise; else 250].
    #[arg(long, value_name = "N|start")]
    integration_window: Option<Integration>,
    /// Degree of the Savitzky–Golay polynomial [default: 3, or the highest derivative the
    /// ARRs read if higher].
    #[arg(long, value_name = "D")]
    degree: Option<u32>,
    /// A fixed threshold on |residual|, as `ARR=LEVEL` (e.g. `ARR1=0.05`); repeat for more.
    /// Residuals without one raise no alarm.
    #[arg(long = "threshold", value_name = "ARR=LEVEL")]
    thresholds: Vec<String>,
    /// A healthy record (same columns and step) to calibrate a threshold for every residual
    /// without `--threshold`: the (1 − P) quantile of |residual| on it (`--false-alarm-rate P`),
    /// times 1 + `--margin`.
    #[arg(long, value_name = "HEALTHY")]
    calibrate: Option<PathBuf>,
    /// The share of healthy samples allowed above a calibrated threshold.
    #[arg(long, value_name = "P", default_value_t = 0.0)]
    false_alarm_rate: f64,
    /// Headroom over the calibrated quantile, as a fraction of it.
    #[arg(long, value_name = "M", default_value_t = 0.2)]
    margin: f64,
    /// Adaptive thresholds: add to each residual's threshold the bound the model's parameter
    /// uncertainties (`+- 5%`) put on it at each sample, `Σ |∂r/∂θ| Δθ`. The fixed or
    /// calibrated level is then the margin for noise on top of it (0 if neither is given).
    /// The bound is derived for the ARRs as written: with it, they are realised directly
    /// (`--realise direct`).
    #[arg(long)]
    adaptive: bool,
    /// Consecutive samples above (below) a threshold that raise (clear) its alarm.
    #[arg(long, value_name = "N", default_value_t = 1)]
    debounce: u32,
    /// Which residuals to evaluate, as `bgc MODEL --residuals` derives them: one ARR per
    /// detector, `best` or `all`.
    #[arg(long, value_enum, value_name = "SET", default_value = "per-sensor")]
    residuals: cli::ResidualsArg,
    /// How the residuals are realised, as `bgc MODEL --realise`: integrated once where that
    /// lowers the derivatives they read, or as written.
    #[arg(long, value_enum, value_name = "HOW", default_value = "lowest")]
    realise: cli::RealiseArg,
    /// Write the CSV to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also draw each residual with its threshold and its alarms shaded, one panel each,
    /// into FILE (SVG).
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
}

/// Runs `bgc residuals`.
pub fn run(args: ResidualArgs) -> Result<(), Failure> {
    // The bound from parameter uncertainty is that of the relation as written.
    let realise = if args.adaptive {
        if args.realise.realise() != Realise::Direct {
            eprintln!(
                "note: --adaptive evaluates the ARRs as written (--realise direct): their bounds \
                 from parameter uncertainty are derived for them"
            );
        }
        Realise::Direct
    } else {
        args.realise.realise()
    };
    // The expressions as `bgc MODEL --emit rust` and `bond_graph!` write them: which ARRs can
    // be integrated depends on the form they are written in, and the two must evaluate the
    // same residuals.
    let c = cli::compile_with(
        &args.model,
        Derive::Everything,
        Some(bondgraph_core::Limits::default()),
        (args.residuals.set(), realise),
    )?;
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
    let shortest = args.window.unwrap_or(calibrate::WINDOWS[0]);
    let data = Data::read(&bytes, &names, shortest).map_err(|e| {
        eprintln!("error: {data_name}: {e}");
        Failure::Invalid
    })?;
    let top = readings.raw.iter().map(|&(_, n)| n).max().unwrap_or(0);
    let degree = args.degree.unwrap_or(top.max(3));
    let mut levels = thresholds(&c, &args.thresholds)?;
    let params: Vec<f64> = c.parameters.iter().map(|(_, p)| p.value).collect();
    let build = |window: usize, integration: &[Integration]| {
        let fit = Fit {
            step: data.step,
            window,
            degree,
            integration: integration.to_vec(),
        };
        Generator::new(&c, &readings, &params, &fit).map_err(|e| {
            eprintln!("error: {e}");
            Failure::Usage
        })
    };
    let mut window = args.window.unwrap_or(calibrate::WINDOWS[0]);
    let mut integration = vec![args.integration_window.unwrap_or_default(); c.arrs.len()];
    // Where a residual taken from the start has its threshold grow with its noise's walk.
    let mut walks: Vec<Option<Walk>> = vec![None; c.arrs.len()];
    if let Some(path) = &args.calibrate {
        let name = path.display().to_string();
        let (_, bytes) = cli::read(path)?;
        let healthy = Data::read(&bytes, &names, shortest).map_err(|e| {
            eprintln!("error: {name}: {e}");
            Failure::Invalid
        })?;
        if (healthy.step - data.step).abs() > STEP_TOLERANCE * data.step {
            eprintln!(
                "error: {name}: its step ({} s) is not the record's ({} s)",
                healthy.step, data.step
            );
            return Err(Failure::Invalid);
        }
        if !(0.0..1.0).contains(&args.false_alarm_rate) || !(0.0..=f64::MAX).contains(&args.margin)
        {
            eprintln!("error: --false-alarm-rate must be in [0, 1) and --margin non-negative");
            return Err(Failure::Usage);
        }
        if args.window.is_none() {
            window = calibrate::longest_steady_window(&|w| build(w, &integration), &healthy)?;
            eprintln!(
                "note: {name}: estimates over {window} samples, the longest window up to which \
                 no residual grows there"
            );
        }
        let which: Vec<bool> = (c.arrs.iter())
            .map(|a| matches!(a.realisation, Realisation::Integrated(_)))
            .collect();
        if args.integration_window.is_none() && which.contains(&true) {
            let chosen = calibrate::longest_integration(
                &|i| build(window, &vec![i; which.len()]),
                &healthy,
                &which,
                window,
            )?;
            (integration, walks) = chosen.into_iter().unzip();
            let said: Vec<String> = (c.arrs.iter().zip(&integration).zip(&which))
                .filter(|(_, &i)| i)
                .map(|((a, i), _)| match i {
                    Integration::Window(n) => format!("{} over {n}", a.name),
                    Integration::Start => format!(
                        "{} from the start (its threshold grows as its noise's random walk)",
                        a.name
                    ),
                })
                .collect();
            eprintln!(
                "note: {name}: integrated residuals taken where their length is largest against \
                 their noise (of {} samples, or from the start where its noise is white plus a \
                 random walk): {}",
                calibrate::INTEGRATIONS.map(|n| n.to_string()).join(", "),
                said.join(", ")
            );
        }
        let calibrated = calibrate::thresholds(
            build(window, &integration)?,
            &healthy,
            &walks,
            args.false_alarm_rate,
            args.margin,
        );
        for ((level, calibrated), walk) in levels.iter_mut().zip(calibrated).zip(&mut walks) {
            // A level the user gave is a level, not a multiple of the walk's deviation.
            if level.is_some() {
                *walk = None;
            }
            level.get_or_insert(calibrated);
        }
    }
    if data.time.len() < window {
        eprintln!(
            "error: {data_name}: {} rows: the estimator's window of {window} samples needs at least {window}",
            data.time.len()
        );
        return Err(Failure::Invalid);
    }
    let mut generator = build(window, &integration)?;
    if args.adaptive {
        // Every residual with a bound gets a threshold: its margin defaults to 0.
        for (level, arr) in levels.iter_mut().zip(&c.arrs) {
            if arr.sensitivities.as_ref().is_some_and(|s| !s.is_empty()) {
                level.get_or_insert(0.0);
            }
        }
    }
    let mut alarms: Vec<Option<Threshold>> = levels
        .iter()
        .map(|l| l.map(|l| Threshold::new(l, args.debounce)))
        .collect();
    let rows: Vec<(&str, Vec<bool>)> = c
        .components
        .iter()
        .map(|(_, comp)| (comp.name.as_str(), comp.signature(c.arrs.len())))
        .collect();
    let n = c.arrs.len();
    let mut raw = vec![0.0; names.len()];
    let mut now: Vec<Option<f64>> = vec![None; n];
    let mut on = vec![false; n];
    let mut drawn = Drawn::new(n, args.plot.is_some());
    // The rows are computed here and written as text by a second thread, chunk by chunk:
    // writing numbers costs about what computing them does.
    let out = std::thread::scope(|scope| {
        let (send, receive) = std::sync::mpsc::sync_channel::<Chunk>(4);
        let rows = &rows;
        let head = header(&c);
        let writer = scope.spawn(move || {
            let mut out = head;
            let mut named = Named::default();
            for chunk in receive {
                chunk.write(&mut out, rows, &mut named);
            }
            (out, named)
        });
        let mut chunk = Chunk::default();
        let mut estimates = 0;
        for (k, &t) in data.time.iter().enumerate() {
            for (v, column) in raw.iter_mut().zip(&data.columns) {
                *v = column[k];
            }
            let Some(e) = generator.push(t, &raw, args.adaptive) else {
                continue;
            };
            for ((((now, on), alarm), walk), ((l, b), &r)) in now
                .iter_mut()
                .zip(&mut on)
                .zip(&mut alarms)
                .zip(&walks)
                .zip(levels.iter().zip(e.bounds).zip(e.residuals))
            {
                *now = l.map(|l| l * walk.map_or(1.0, |w| w.deviation(estimates)) + b);
                *on = match (alarm.as_mut(), *now) {
                    (Some(a), Some(l)) => a.update_with_level(r, l),
                    _ => false,
                };
            }
            chunk.push(e.at, e.residuals, &now, &on);
            estimates += 1;
            drawn.push(e.at, e.residuals, &now, &on);
            if chunk.time.len() == CHUNK_ROWS {
                // The writer stops only when this side has: it cannot have gone away.
                let _ = send.send(std::mem::take(&mut chunk));
            }
        }
        let _ = send.send(chunk);
        drop(send);
        writer.join().unwrap_or_default()
    });
    let (out, named) = out;
    named.report(&rows, &c);
    if let Some(path) = &args.plot {
        drawn.draw(path, &c).map_err(|e| {
            eprintln!("error: {e}");
            Failure::Usage
        })?;
    }
    cli::write(args.output.as_deref(), &out)
}

/// What `--plot` draws, kept as the rows are computed.
struct Drawn {
    keep: bool,
    time: Vec<f64>,
    residuals: Vec<Vec<f64>>,
    thresholds: Vec<Vec<f64>>,
    alarms: Vec<Vec<bool>>,
    /// Whether each residual has a threshold at all.
    has_threshold: Vec<bool>,
}

impl Drawn {
    fn new(n: usize, keep: bool) -> Drawn {
        Drawn {
            keep,
            time: Vec::new(),
            residuals: vec![Vec::new(); n],
            thresholds: vec![Vec::new(); n],
            alarms: vec![Vec::new(); n],
            has_threshold: vec![false; n],
        }
    }

    fn push(&mut self, t: f64, residuals: &[f64], thresholds: &[Option<f64>], on: &[bool]) {
        if !self.keep {
            return;
        }
        self.time.push(t);
        for k in 0..residuals.len() {
            self.residuals[k].push(residuals[k]);
            self.thresholds[k].push(thresholds[k].unwrap_or(0.0));
            self.has_threshold[k] |= thresholds[k].is_some();
            self.alarms[k].push(on[k]);
        }
    }

    fn draw(&self, path: &std::path::Path, c: &Compiled) -> Result<(), String> {
        // `ARR1 (junction elec, sensor y1)`: where each residual comes from.
        let titles: Vec<String> = c
            .arrs
            .iter()
            .map(|arr| match arr.sensor {
                Some(s) => format!(
                    "{} (junction {}, sensor {})",
                    arr.name, arr.junction, c.sensors[s].name
                ),
                None => format!("{} (junction {})", arr.name, arr.junction),
            })
            .collect();
        let panels: Vec<crate::plot::Panel<'_>> = c
            .arrs
            .iter()
            .zip(&titles)
            .enumerate()
            .map(|(k, (_, title))| crate::plot::Panel {
                name: title,
                values: &self.residuals[k],
                threshold: self.has_threshold[k].then_some(self.thresholds[k].as_slice()),
                alarm: self.has_threshold[k].then_some(self.alarms[k].as_slice()),
            })
            .collect();
        crate::plot::draw(path, &self.time, &panels)
    }
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
    h.push_str(",candidates,suspects,episode\n");
    h
}

/// Rows handed to the writer at once.
const CHUNK_ROWS: usize = 4096;

/// Computed rows on their way to the writer: per row, the time, then each residual, its
/// threshold (if any) and its alarm.
#[derive(Default)]
struct Chunk {
    time: Vec<f64>,
    residuals: Vec<f64>,
    levels: Vec<Option<f64>>,
    on: Vec<bool>,
}

impl Chunk {
    fn push(&mut self, t: f64, residuals: &[f64], levels: &[Option<f64>], on: &[bool]) {
        self.time.push(t);
        self.residuals.extend(residuals);
        self.levels.extend(levels);
        self.on.extend(on);
    }

    /// Appends the rows as CSV, with the candidates and the suspects of each row's alarms.
    fn write(&self, out: &mut String, rows: &[(&str, Vec<bool>)], named: &mut Named) {
        let n = self.residuals.len() / self.time.len().max(1);
        for (k, &t) in self.time.iter().enumerate() {
            let span = k * n..(k + 1) * n;
            let on = &self.on[span.clone()];
            cli::push_number(out, t);
            for &r in &self.residuals[span.clone()] {
                out.push(',');
                cli::push_number(out, r);
            }
            for l in &self.levels[span] {
                out.push(',');
                if let Some(l) = *l {
                    cli::push_number(out, l);
                }
            }
            for &a in on {
                out.push_str(if a { ",1" } else { ",0" });
            }
            named.cells(rows, t, on, out);
            out.push('\n');
        }
    }
}

/// The candidates and suspects cells of the last alarm pattern, and the episode's candidates
/// for the residuals seen in alarm so far: alarms change seldom, and naming them for every row
/// would cost more than the rest of the row.
#[derive(Default)]
struct Named {
    alarms: Vec<bool>,
    cells: String,
    episode: Option<Episode>,
    /// When the episode started.
    first: Option<f64>,
    seen: Vec<bool>,
    episode_cell: String,
}

impl Named {
    /// `,candidates,suspects,episode` for the alarms `on` at `t`.
    fn cells(&mut self, rows: &[(&str, Vec<bool>)], t: f64, on: &[bool], out: &mut String) {
        let fsm = || rows.iter().map(|(n, s)| (*n, s.as_slice()));
        if self.alarms != on || self.cells.is_empty() {
            self.cells = format!(
                ",{},{}",
                bondgraph::candidates(fsm(), on).join(" "),
                bondgraph::suspects(fsm(), on).join(" ")
            );
            self.alarms.clear();
            self.alarms.extend_from_slice(on);
        }
        out.push_str(&self.cells);
        let episode = self.episode.get_or_insert_with(|| Episode::new(on.len()));
        episode.push(on);
        if episode.started() {
            self.first.get_or_insert(t);
            let seen = episode.seen();
            if seen != self.seen || self.episode_cell.is_empty() {
                self.episode_cell = format!(",{}", episode.candidates(fsm()).join(" "));
                self.seen = seen;
            }
            out.push_str(&self.episode_cell);
        } else {
            out.push(',');
        }
    }

    /// The ranking of the components by the whole episode, on standard error.
    fn report(&self, rows: &[(&str, Vec<bool>)], c: &Compiled) {
        let (Some(episode), Some(first)) = (&self.episode, self.first) else {
            return;
        };
        let shares: Vec<String> = (c.arrs.iter().zip(episode.shares()))
            .map(|(a, s)| format!("{} {:.1} %", a.name, 100.0 * s))
            .collect();
        eprintln!(
            "note: alarms from {first} s on: {} of the samples since (seen in alarm from \
             {} %); the components by how well a single fault of each explains them:",
            shares.join(", "),
            100.0 * Episode::SEEN
        );
        let fsm = rows.iter().map(|(n, s)| (*n, s.as_slice()));
        for (k, r) in episode.rank(fsm).iter().enumerate() {
            let why = match (r.unexplained, r.unseen) {
                (0, 0) => "matches every residual seen in alarm".to_string(),
                (0, n) => format!("{n} residual(s) of its signature not seen in alarm"),
                (m, n) => format!(
                    "{m} residual(s) in alarm outside its signature (up to {:.1} % of the time), \
                     {n} of it not seen",
                    100.0 * r.share
                ),
            };
            eprintln!("  {:>2}  {}: {why}", k + 1, r.names.join(" "));
        }
    }
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
            .trim(csv::Trim::Headers)
            .from_reader(bytes);
        let header = reader
            .headers()
            .map_err(|e| format!("cannot read the header: {e}"))?
            .clone();
        let find = |name: &str| header.iter().position(|h| h == name);
        let t = find("t").ok_or("no time column: the header needs a column named `t`")?;
        let mut at = vec![t];
        for name in names {
            at.push(find(name).ok_or_else(|| {
                format!(
                    "no column `{name}`: the ARRs read {}; the header has {}",
                    names.join(", "),
                    header.iter().collect::<Vec<_>>().join(", ")
                )
            })?);
        }
        let column_names: Vec<&str> = std::iter::once("t")
            .chain(names.iter().map(String::as_str))
            .collect();
        let start = usize::try_from(reader.position().byte()).unwrap_or(bytes.len());
        let body = bytes.get(start..).unwrap_or_default();
        let mut columns = parse_rows(body, &at, &column_names)?;
        let time = columns.remove(0);
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

/// The rows of `body` (the CSV after its header, which was line 1), the cells at `at` of each
/// as numbers, by column. A large record is parsed in two halves at once, split at a line
/// end: parsing is a good part of `bgc residuals`' time, and a machine has two cores at
/// least. A record with quotes, where a line end may sit inside a cell, is parsed in one go.
fn parse_rows(body: &[u8], at: &[usize], names: &[&str]) -> Result<Vec<Vec<f64>>, String> {
    let split = (body.len() > 1 << 20 && !body.contains(&b'"'))
        .then(|| {
            let middle = body.len() / 2;
            body[middle..]
                .iter()
                .position(|&b| b == b'\n')
                .map(|k| middle + k + 1)
        })
        .flatten();
    let Some(split) = split else {
        return parse_part(body, at, names, 2);
    };
    let (first, second) = body.split_at(split);
    let second_line = 2 + first.iter().filter(|&&b| b == b'\n').count();
    let (head, tail) = std::thread::scope(|scope| {
        let tail = scope.spawn(|| parse_part(second, at, names, second_line));
        let head = parse_part(first, at, names, 2);
        (head, tail.join())
    });
    // The first half's mistake comes first: it is on an earlier line.
    let mut columns = head?;
    let tail = tail.map_err(|_| "the parser of the record's second half failed".to_string())??;
    for (column, rest) in columns.iter_mut().zip(tail) {
        column.extend(rest);
    }
    Ok(columns)
}

/// The rows of `part`, whose first line is `line` of the file.
fn parse_part(
    part: &[u8],
    at: &[usize],
    names: &[&str],
    mut line: usize,
) -> Result<Vec<Vec<f64>>, String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(part);
    let rows = part.iter().filter(|&&b| b == b'\n').count() + 1;
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows); at.len()];
    // One record reused for every row: no allocation per row.
    let mut record = csv::ByteRecord::new();
    loop {
        match reader.read_byte_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(format!("line {line}: {e}")),
        }
        for ((column, &i), name) in columns.iter_mut().zip(at).zip(names) {
            let cell = record.get(i).unwrap_or(b"");
            let text = std::str::from_utf8(cell).unwrap_or("").trim();
            let value = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "line {line}, column `{name}`: `{}` is not a finite number",
                        String::from_utf8_lossy(cell).trim()
                    )
                })?;
            column.push(value);
        }
        line += 1;
    }
    Ok(columns)
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

/// An auxiliary signal's derivative: which, and its order.
type AuxKey = (Handle<bondgraph_core::Auxiliary>, u32);

/// A leaf of the generator's expressions: a slot of the estimated quantities, an auxiliary
/// signal's derivative by position, or time. Parameters are folded in as numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum Leaf {
    Slot(u32),
    Auxiliary(u32),
    Time,
    /// What a generator cannot read (a state): never in an ARR.
    Missing,
    /// A signal's value the residuals read only under an integral: never evaluated.
    Unestimated(Quantity),
}

type Id = ExprId<Leaf>;

/// A leaf of the copy of the model's rates: a state (the model's, then its integrals), an
/// input by position, or time. Parameters are folded in as numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum CopyLeaf {
    State(u32),
    Input(u32),
    Time,
    Missing,
}

/// The copy of the model simulated residuals run, as the generated code runs it.
struct CopyRun {
    replay: bondgraph::Replay,
    rates: Tape<CopyLeaf>,
    /// Each `int(..)` node of the rates, with the state that holds it.
    int_states: Vec<(ExprId<CopyLeaf>, usize)>,
    /// The raw index of each input the rates read.
    inputs: Vec<usize>,
    /// Each simulated quantity's slot and the copy's state it reads.
    read: Vec<(usize, usize)>,
    /// Reused between samples.
    u: Vec<f64>,
    scratch: Vec<f64>,
    out: Vec<f64>,
}

impl CopyRun {
    /// The copy of `c`'s model, when its simulated residuals need one.
    fn new(
        c: &Compiled,
        readings: &Readings,
        params: &[f64],
        slot: &HashMap<Quantity, usize>,
    ) -> Option<CopyRun> {
        let copy = readings.copy.as_ref()?;
        let inputs = &copy.inputs;
        let mut pool: Pool<CopyLeaf> = Pool::default();
        let import = |pool: &mut Pool<CopyLeaf>, e: Expr| {
            pool.import_from(&c.exprs, e, |p: &mut Pool<CopyLeaf>, s| match s {
                Symbol::Parameter(k) => p.num(params.get(k.index()).copied().unwrap_or(f64::NAN)),
                Symbol::State(k) => p.leaf(CopyLeaf::State(k.index() as u32)),
                Symbol::Input(u, 0) => p.leaf(
                    inputs
                        .iter()
                        .position(|&i| i == u)
                        .map_or(CopyLeaf::Missing, |j| CopyLeaf::Input(j as u32)),
                ),
                Symbol::Time => p.leaf(CopyLeaf::Time),
                _ => p.leaf(CopyLeaf::Missing),
            })
        };
        let rates: Vec<ExprId<CopyLeaf>> =
            copy.rates.iter().map(|&e| import(&mut pool, e)).collect();
        let int_states = (copy.integrals.iter().enumerate())
            .map(|(k, &arg)| {
                let arg = import(&mut pool, arg);
                (pool.int(arg), c.states.len() + k)
            })
            .collect();
        let read = (readings.quantities.iter())
            .filter_map(|q| match q {
                Quantity::Simulated(k) => Some((slot.get(q).copied()?, k.index())),
                _ => None,
            })
            .collect();
        let raw_index = |u: Handle<bondgraph_core::Input>| {
            (readings.raw.iter()).position(|&(s, _)| s == Signal::Input(u))
        };
        Some(CopyRun {
            replay: bondgraph::Replay::new(&vec![0.0; copy.rates.len()]),
            rates: Tape::new(&pool, &rates),
            int_states,
            inputs: inputs
                .iter()
                .map(|&u| raw_index(u))
                .collect::<Option<_>>()?,
            read,
            u: vec![0.0; inputs.len()],
            scratch: Vec::new(),
            out: Vec::new(),
        })
    }

    /// Advances the copy to the raw samples at `t`.
    fn push(&mut self, t: f64, raw: &[f64]) {
        for (u, &k) in self.u.iter_mut().zip(&self.inputs) {
            *u = raw.get(k).copied().unwrap_or(f64::NAN);
        }
        let CopyRun {
            replay,
            rates,
            int_states,
            u,
            scratch,
            out,
            ..
        } = self;
        replay.push(t, u, |t, x, u, dx| {
            let leaf = |l: CopyLeaf| match l {
                CopyLeaf::State(k) => x.get(k as usize).copied().unwrap_or(f64::NAN),
                CopyLeaf::Input(j) => u.get(j as usize).copied().unwrap_or(f64::NAN),
                CopyLeaf::Time => t,
                CopyLeaf::Missing => f64::NAN,
            };
            let integral = |id: ExprId<CopyLeaf>| {
                (int_states.iter().find(|(i, _)| *i == id))
                    .and_then(|&(_, k)| x.get(k).copied())
                    .unwrap_or(f64::NAN)
            };
            rates.values_into(leaf, integral, scratch, out);
            dx.copy_from_slice(out);
        });
    }
}

/// The residual generator of a compiled model, read at run time: the same estimators, in the
/// same order, as the generated `ResidualGenerator`.
pub struct Generator {
    estimators: Vec<SavitzkyGolay>,
    /// For each raw signal, the slots of the derivatives read, by order.
    scatter: Vec<Vec<(usize, usize)>>,
    /// Each integrated signal's raw index, slot, trapezoidal integral and its fit.
    integrals: Vec<(usize, usize, Trapezoid, SavitzkyGolay)>,
    /// Each nonlinear integral's slot and rule.
    nonlinear: Vec<(usize, Trapezoid)>,
    integrands: Tape<Leaf>,
    /// Each auxiliary derivative, in definition order.
    auxiliaries: Vec<Tape<Leaf>>,
    arrs: Tape<Leaf>,
    /// Every sensitivity `∂r/∂θ` of every ARR, in order.
    sensitivities: Tape<Leaf>,
    /// For each of them, its ARR and `Δθ`.
    weights: Vec<(usize, f64)>,
    /// Each `int(..)` node: a combination of integral slots with coefficients.
    int_nodes: Vec<(Id, Vec<(f64, usize)>)>,
    delay: f64,
    values: Vec<f64>,
    auxiliary: Vec<f64>,
    int_values: Vec<(Id, f64)>,
    /// Reused between samples, so that a sample allocates nothing.
    scratch: Vec<f64>,
    buffer: Vec<f64>,
    residuals: Vec<f64>,
    bounds: Vec<f64>,
    /// The copy of the model simulated residuals run, if any.
    copy: Option<CopyRun>,
    /// Each residual realised by integration, with its reference.
    references: Vec<(usize, Reference)>,
}

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
    fn reference(self) -> Reference {
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

/// How a [`Generator`] estimates: Savitzky–Golay fits of `degree` over `window` samples every
/// `step` seconds, and over what residuals realised by integration are integrated.
pub struct Fit {
    /// The record's step, in seconds.
    pub step: f64,
    /// Samples in each fit (odd).
    pub window: usize,
    /// The fits' polynomial degree.
    pub degree: u32,
    /// Over what each integrated residual is taken (by ARR; the default past the end).
    pub integration: Vec<Integration>,
}

/// The residuals at one instant, as [`Generator::push`] gives them.
pub struct Estimate<'g> {
    /// The instant of the estimates: the sample's time minus the estimators' delay.
    pub at: f64,
    /// Each ARR's residual.
    pub residuals: &'g [f64],
    /// Each residual's bound from parameter uncertainty (zeros when not asked for).
    pub bounds: &'g [f64],
}

impl Generator {
    /// The generator of `c`'s residuals with the parameters `params`, estimating as `how`
    /// says.
    pub fn new(
        c: &Compiled,
        readings: &Readings,
        params: &[f64],
        how: &Fit,
    ) -> Result<Generator, bondgraph::EstimatorError> {
        let fit = |order: u32| SavitzkyGolay::new(order, how.degree, how.window, how.step, true);
        let estimators = readings
            .raw
            .iter()
            .map(|&(_, n)| fit(n))
            .collect::<Result<Vec<_>, _>>()?;
        let slot: HashMap<Quantity, usize> = readings
            .quantities
            .iter()
            .enumerate()
            .map(|(i, &q)| (q, i))
            .collect();
        let scatter = readings
            .raw
            .iter()
            .map(|&(signal, top)| {
                (0..=top)
                    .filter_map(|n| {
                        slot.get(&Quantity::Derivative(signal, n))
                            .map(|&i| (n as usize, i))
                    })
                    .collect()
            })
            .collect();
        let integrals = readings
            .integrated
            .iter()
            .map(|s| {
                let k = readings.raw.iter().position(|(r, _)| r == s).unwrap_or(0);
                let i = slot.get(&Quantity::Integral(*s)).copied().unwrap_or(0);
                Ok((k, i, Trapezoid::new(), fit(0)?))
            })
            .collect::<Result<Vec<_>, bondgraph::EstimatorError>>()?;
        let delay = estimators
            .iter()
            .map(Differentiator::delay)
            .fold(0.0, f64::max);
        let aux_index: HashMap<AuxKey, u32> = c
            .auxiliaries
            .iter()
            .flat_map(|(a, aux)| (0u32..).zip(&aux.derivatives).map(move |(n, _)| (a, n)))
            .zip(0u32..)
            .collect();
        // Every expression in one pool over the generator's leaves, parameters folded.
        let mut pool: Pool<Leaf> = Pool::default();
        let import = |pool: &mut Pool<Leaf>, e: Expr| {
            pool.import_from(&c.exprs, e, |p: &mut Pool<Leaf>, s| match s {
                Symbol::Parameter(k) => p.num(params.get(k.index()).copied().unwrap_or(f64::NAN)),
                Symbol::Input(u, n) => {
                    slot_leaf(p, &slot, Quantity::Derivative(Signal::Input(u), n))
                }
                Symbol::Sensor(h, n) => {
                    slot_leaf(p, &slot, Quantity::Derivative(Signal::Sensor(h), n))
                }
                Symbol::Auxiliary(a, n) => p.leaf(
                    aux_index
                        .get(&(a, n))
                        .map_or(Leaf::Missing, |&j| Leaf::Auxiliary(j)),
                ),
                Symbol::Time => p.leaf(Leaf::Time),
                // A simulated residual reads the states of the copy of the model.
                Symbol::State(k) => slot_leaf(p, &slot, Quantity::Simulated(k)),
                Symbol::Loop(_) => p.leaf(Leaf::Missing),
            })
        };
        let integrands: Vec<Id> = readings
            .nonlinear
            .iter()
            .map(|&e| import(&mut pool, e))
            .collect();
        let auxiliaries: Vec<Id> = c
            .auxiliaries
            .iter()
            .flat_map(|(_, a)| a.derivatives.iter().copied())
            .map(|e| import(&mut pool, e))
            .collect();
        let arrs: Vec<Id> = (c.arrs.iter())
            .map(|a| import(&mut pool, a.evaluated()))
            .collect();
        let mut weights = Vec::new();
        let mut sensitivities = Vec::new();
        for (k, arr) in c.arrs.iter().enumerate() {
            for &(p, e) in arr.sensitivities.iter().flatten() {
                weights.push((k, c.parameters[p].uncertainty.unwrap_or(0.0)));
                sensitivities.push(import(&mut pool, e));
            }
        }
        // Each `int(..)` of the product, found where the import put it.
        let mut original = Vec::new();
        let mut roots: Vec<Expr> = c.arrs.iter().map(Arr::evaluated).collect();
        roots.extend(
            c.arrs
                .iter()
                .flat_map(|a| a.sensitivities.iter().flatten().map(|&(_, e)| e)),
        );
        roots.extend(
            c.auxiliaries
                .iter()
                .flat_map(|(_, a)| a.derivatives.iter().copied()),
        );
        roots.extend(readings.nonlinear.iter().copied());
        c.exprs.visit_reachable(&roots, |_, node| {
            if let Node::Int(arg) = node {
                original.push(arg);
            }
        });
        let coefficient = |e: Option<Expr>| {
            e.map_or(1.0, |e| {
                bondgraph_core::Evaluator::new(&c.exprs, |s| match s {
                    Symbol::Parameter(p) => params.get(p.index()).copied().unwrap_or(f64::NAN),
                    _ => f64::NAN,
                })
                .value(e)
            })
        };
        let mut int_nodes = Vec::new();
        for arg in original {
            let imported = import(&mut pool, arg);
            let id = pool.int(imported);
            let terms = match readings.nonlinear.iter().position(|&e| e == arg) {
                Some(k) => vec![(1.0, slot.get(&Quantity::Nonlinear(k)).copied())],
                None => c
                    .linear_terms(arg)
                    .unwrap_or_default()
                    .into_iter()
                    .map(|(plus, k, signal)| {
                        let v = coefficient(k);
                        (
                            if plus { v } else { -v },
                            slot.get(&Quantity::Integral(signal)).copied(),
                        )
                    })
                    .collect(),
            };
            // A term without a slot cannot happen (the readings list every integral read);
            // if it did, NaN makes the residual refuse to pass for healthy.
            let terms = terms
                .into_iter()
                .map(|(c, i)| i.map_or((f64::NAN, 0), |i| (c, i)))
                .collect();
            int_nodes.push((id, terms));
        }
        let nonlinear = (0..readings.nonlinear.len())
            .map(|k| {
                (
                    slot.get(&Quantity::Nonlinear(k)).copied().unwrap_or(0),
                    Trapezoid::new(),
                )
            })
            .collect();
        Ok(Generator {
            estimators,
            scatter,
            integrals,
            nonlinear,
            integrands: Tape::new(&pool, &integrands),
            auxiliaries: auxiliaries
                .iter()
                .map(|&e| Tape::new(&pool, &[e]))
                .collect(),
            arrs: Tape::new(&pool, &arrs),
            sensitivities: Tape::new(&pool, &sensitivities),
            weights,
            int_values: int_nodes.iter().map(|&(id, _)| (id, 0.0)).collect(),
            int_nodes,
            delay,
            values: vec![0.0; readings.quantities.len()],
            auxiliary: vec![0.0; aux_index.len()],
            scratch: Vec::new(),
            buffer: Vec::new(),
            residuals: Vec::new(),
            bounds: Vec::new(),
            copy: CopyRun::new(c, readings, params, &slot),
            references: (c.arrs.iter().enumerate())
                .filter(|(_, a)| matches!(a.realisation, Realisation::Integrated(_)))
                .map(|(k, _)| {
                    let over = how.integration.get(k).copied().unwrap_or_default();
                    (k, over.reference())
                })
                .collect(),
        })
    }

    /// Takes the raw samples at `t` (in [`Readings::raw`] order) and returns, once the windows
    /// are full, the residuals at the instant of the estimates and, with `bounds`, each
    /// residual's bound from parameter uncertainty, `Σ |∂r/∂θ| Δθ` (else zeros).
    pub fn push(&mut self, t: f64, raw: &[f64], bounds: bool) -> Option<Estimate<'_>> {
        if let Some(copy) = &mut self.copy {
            copy.push(t, raw);
        }
        let mut ready = true;
        for (k, (e, &x)) in self.estimators.iter_mut().zip(raw).enumerate() {
            match e.push(x) {
                Some(d) => {
                    for &(n, i) in &self.scatter[k] {
                        self.values[i] = d.get(n).copied().unwrap_or(f64::NAN);
                    }
                }
                None => ready = false,
            }
        }
        for (k, i, integral, fit) in &mut self.integrals {
            match fit.push(integral.push(t, raw[*k])) {
                Some(d) => self.values[*i] = d.first().copied().unwrap_or(f64::NAN),
                None => ready = false,
            }
        }
        if !ready {
            return None;
        }
        let at = t - self.delay;
        if let Some(copy) = &mut self.copy {
            let x = copy.replay.at(at)?;
            for &(i, k) in &copy.read {
                self.values[i] = x.get(k).copied().unwrap_or(f64::NAN);
            }
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        let mut buffer = std::mem::take(&mut self.buffer);
        if !self.nonlinear.is_empty() {
            self.update_integrals();
            self.evaluate(&self.integrands, at, &mut scratch, &mut buffer);
            for ((i, trapezoid), &v) in self.nonlinear.iter_mut().zip(&buffer) {
                self.values[*i] = trapezoid.push(at, v);
            }
        }
        self.update_integrals();
        for j in 0..self.auxiliaries.len() {
            self.evaluate(&self.auxiliaries[j], at, &mut scratch, &mut buffer);
            self.auxiliary[j] = buffer.first().copied().unwrap_or(f64::NAN);
        }
        let mut residuals = std::mem::take(&mut self.residuals);
        self.evaluate(&self.arrs, at, &mut scratch, &mut residuals);
        for (k, reference) in &mut self.references {
            if let Some(r) = residuals.get_mut(*k) {
                *r = reference.push(*r);
            }
        }
        self.bounds.clear();
        self.bounds.resize(residuals.len(), 0.0);
        if bounds && !self.weights.is_empty() {
            self.evaluate(&self.sensitivities, at, &mut scratch, &mut buffer);
            for (&(k, delta), s) in self.weights.iter().zip(&buffer) {
                self.bounds[k] += s.abs() * delta;
            }
        }
        self.scratch = scratch;
        self.buffer = buffer;
        self.residuals = residuals;
        Some(Estimate {
            at,
            residuals: &self.residuals,
            bounds: &self.bounds,
        })
    }

    /// The roots of `tape` at `at` into `out`.
    fn evaluate(&self, tape: &Tape<Leaf>, at: f64, scratch: &mut Vec<f64>, out: &mut Vec<f64>) {
        tape.values_into(|l| self.leaf(l, at), |id| self.integral(id), scratch, out);
    }

    fn update_integrals(&mut self) {
        for ((_, value), (_, terms)) in self.int_values.iter_mut().zip(&self.int_nodes) {
            *value = terms.iter().map(|&(c, i)| c * self.values[i]).sum();
        }
    }

    fn leaf(&self, l: Leaf, t: f64) -> f64 {
        match l {
            Leaf::Slot(i) => self.values[i as usize],
            Leaf::Auxiliary(j) => self.auxiliary[j as usize],
            Leaf::Time => t,
            Leaf::Missing | Leaf::Unestimated(_) => f64::NAN,
        }
    }

    fn integral(&self, id: Id) -> f64 {
        self.int_values
            .iter()
            .find(|(x, _)| *x == id)
            .map_or(f64::NAN, |&(_, v)| v)
    }
}

/// The slot of `q`; a quantity without one (a signal read only under an integral) is a
/// leaf of its own, so that the integrals of two such signals stay two nodes.
fn slot_leaf(p: &mut Pool<Leaf>, slot: &HashMap<Quantity, usize>, q: Quantity) -> Id {
    p.leaf(
        slot.get(&q)
            .map_or(Leaf::Unestimated(q), |&i| Leaf::Slot(i as u32)),
    )
}
