//! `bgc residuals`: the ARRs evaluated over recorded samples, with thresholds, alarms and the
//! candidate components.
//!
//! The residuals are computed by running the model's residual program (the one the
//! generated `ResidualGenerator` is printed from) in `bondgraph-interpreter`: the same
//! runtime estimators in the same order, so the two agree to rounding.

use std::fmt::Write as _;
use std::path::PathBuf;

use bondgraph::{Cusum, Episode, Signature, Threshold};
use bondgraph_core::program::{Program, Stability};
use bondgraph_core::{Compiled, Derive, Realisation, Realise, ResidualForm};
use bondgraph_interpreter::{
    calibrate, fnv1a, window_of, Calibration, Choices, Conditioning, CusumLevels, Decision,
    Estimator, EstimatorKind, FalseAlarms, Fit, Generator, Hold, Holding, Integration, Mismatch,
    Range, Samples, Singular, SizeOver, Walk, GAIN, STEP_TOLERANCE, WINDOWS,
};

use crate::identify::significant;
use crate::io;
use crate::options::ResidualChoice;
use crate::record::{Data, Layout};
use crate::report::{self, Failure};

/// `--estimator`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum EstimatorArg {
    /// A least-squares polynomial over the window, for each signal.
    SavitzkyGolay,
    /// Integration by parts against one smooth window for every signal and order.
    Modulating,
}

impl EstimatorArg {
    /// The interpreter's name for it.
    fn kind(self) -> EstimatorKind {
        match self {
            EstimatorArg::SavitzkyGolay => EstimatorKind::SavitzkyGolay,
            EstimatorArg::Modulating => EstimatorKind::Modulating,
        }
    }
}

/// What `bgc residuals` takes.
#[derive(clap::Args, Debug)]
pub(crate) struct ResidualArgs {
    /// The model.
    #[arg(value_name = "MODEL")]
    model: PathBuf,
    /// The recorded samples: CSV with a header, Parquet, a Matlab MAT-file, TDMS or MDF 4
    /// (told by their first bytes), with a time column `t` (in MDF, the master channel) at a
    /// uniform step and one column per input and measured signal the ARRs read, named as in
    /// the model (or as `--time` and `--column` say).
    #[arg(value_name = "DATA")]
    data: PathBuf,
    /// The record's time column, where it is not `t`.
    #[arg(long, value_name = "NAME", default_value = "t")]
    time: String,
    /// The record's column of a signal named otherwise in the model, as `SIGNAL=COLUMN`
    /// (e.g. `y1=motor_speed`); repeat for more. Applies to `--calibrate`'s record too,
    /// unless `--calibrate-column` maps that signal there.
    #[arg(long = "column", value_name = "SIGNAL=COLUMN")]
    columns: Vec<String>,
    /// `--calibrate`'s record's column of a signal, where it differs from the record's
    /// (`--column`), as `SIGNAL=COLUMN`: a healthy record holds the measured force as
    /// `force` where the record under test reads the controller's part, `force_ctrl`.
    #[arg(
        long = "calibrate-column",
        value_name = "SIGNAL=COLUMN",
        requires = "calibrate"
    )]
    calibrate_columns: Vec<String>,
    /// Samples in the estimators' window (odd) [default: with `--calibrate`, for fits the
    /// longest of 11, 21, 51, 101, 201 and 501 samples (at most a tenth of the healthy
    /// record) up to which no residual's RMS on the healthy record grows, for modulating
    /// functions the window chosen with them (see `--estimator`); else 11 for fits, 101 for
    /// modulating functions].
    #[arg(long, value_name = "N")]
    window: Option<usize>,
    /// Residuals realised by integration (`integrated` in the model's output) are the
    /// relation's integral over the last N samples, or from the record's first estimate
    /// (`start`): a fault that shows only while a signal moves then leaves them offset for
    /// good, but the noise they integrate grows with the record. Given, it is each such
    /// residual's one test [default: with `--calibrate`, two tests per residual: over a
    /// quarter of the estimators' window (onsets and ends), and a hold, from the start where
    /// the relation reads a signal integrated from the start, else the one of 250, 1000,
    /// 2500, 10000 and 25000 samples and `--within` (at most a twentieth of the healthy
    /// record), or from the start where its noise there is white plus a random walk, under
    /// which a fault that persists moves it most against its noise over the healthy record
    /// (a window; over the second half of `--within`, where given), restarted at the end of
    /// the onset alarms it rose with; else 250].
    #[arg(long, value_name = "N|start")]
    integration_window: Option<Integration>,
    /// How the signals' values and derivatives are estimated over the window:
    /// `savitzky-golay` fits a polynomial to each; `modulating` integrates by parts against
    /// one smooth window `sᵃ(T − s)ᵃ` for every signal and order, so that no sample is
    /// differentiated and an ARR linear in the signals holds on the estimates at any window
    /// [default: with `--calibrate`, for ARRs linear in the signals, the one (with its window)
    /// under whose calibrated thresholds a fault of a fifth of a parameter shows most; else
    /// savitzky-golay].
    #[arg(long, value_enum, value_name = "KIND")]
    estimator: Option<EstimatorArg>,
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
    /// Also write what `--calibrate` chose (the parameters as fitted, the estimator, each
    /// residual's integration and threshold) to FILE, for `--calibration`.
    #[arg(long, value_name = "FILE", requires = "calibrate")]
    save_calibration: Option<PathBuf>,
    /// Decide as a kept calibration says (a file `--save-calibration` wrote for this model),
    /// without recalibrating: its parameters, estimator, integrations and thresholds.
    /// `--threshold` still sets a residual's level.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["calibrate", "window", "estimator", "integration_window", "degree", "adaptive", "params"]
    )]
    calibration: Option<PathBuf>,
    /// Read the record (and `--calibrate`'s) from this time on, in seconds of its own time
    /// column: a start-up the model does not hold through (a relation dividing by a speed
    /// at rest) is then neither calibrated on nor alarmed on, and the residuals start there.
    #[arg(long, value_name = "SECONDS")]
    from: Option<f64>,
    /// The false alarms a calibrated threshold allows: a rate of healthy records crossing
    /// it, per unit of time (`1/h`, `0.5/min`, `1e-3/s`, `1/d`), which sets each threshold at
    /// the level a healthy record as long as the calibration's crosses with that record's
    /// share of it; or a share P of the healthy samples above it (a bare number, the
    /// (1 − P) quantile) [default: 0, the largest, and at least the level crossed with
    /// probability 1e-3 per record of the healthy one's length].
    #[arg(long, value_name = "RATE|P", default_value = "0")]
    false_alarm_rate: FalseAlarms,
    /// With `--calibrate`, keep the model's parameter values: by default they are first
    /// fitted to the healthy record (as `bgc identify` fits them), and the thresholds are set
    /// on the fitted model.
    #[arg(long, requires = "calibrate")]
    keep_model: bool,
    /// With `--calibrate`, a sequential test beside each threshold, for small persistent
    /// faults: a CUSUM on the residual over its noise's deviation, with drift K deviations
    /// (half the shift it is tuned for; at least what the model's error leaves on the healthy
    /// record), its level calibrated as the thresholds are. An alarm is either test's; the
    /// stated false-alarm probability is shared between the two.
    #[arg(
        long,
        value_name = "K",
        num_args = 0..=1,
        default_missing_value = "0.5",
        requires = "calibrate"
    )]
    cusum: Option<f64>,
    /// With `--calibrate`, the time after a fault by which it should show, in seconds of
    /// the record's time: each integrated residual's hold (where it does not read a signal
    /// integrated from the start) is the window under which a fault gets the most margin
    /// over its threshold then. Without it, the hold is the window under which a fault that
    /// persists gets the most margin over the healthy record's length, so that it stays in
    /// alarm while the fault lasts.
    #[arg(long, value_name = "SECONDS", requires = "calibrate")]
    within: Option<f64>,
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
    #[command(flatten)]
    choice: ResidualChoice,
    #[command(flatten)]
    values: crate::options::ValuesArg,
    /// Do not size the fault: by default, once the residuals alarm, each candidate
    /// component's parameters are fitted alone over `--size-span` seconds from the first
    /// alarm, and the candidates ranked by how well that explains every residual.
    #[arg(long)]
    no_size: bool,
    /// The seconds from the first alarm the fault's size is fitted over (at least 102
    /// samples: twice the sizes' estimator window).
    #[arg(long, value_name = "SECONDS", default_value_t = 5.0)]
    size_span: f64,
    /// Also follow the best candidate's parameters over successive spans to the record's
    /// end, written as CSV to FILE (`from,to,component,parameter,value,half_width,ratio`):
    /// the trend of a drifting fault.
    #[arg(long, value_name = "FILE")]
    sizes: Option<PathBuf>,
    /// Write the CSV to FILE instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Also draw each residual with its threshold and its alarms shaded, one panel each,
    /// into FILE (SVG).
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
}

/// Runs `bgc residuals`.
pub(crate) fn run(mut args: ResidualArgs) -> Result<(), Failure> {
    // The bounds of `--adaptive` are the ARRs' as written, which a copy has none of; a
    // record read `--from` a later instant does not start where a copy does (at rest).
    let deciding = (args.calibrate.is_some() || args.calibration.is_some())
        && !args.adaptive
        && args.from.is_none();
    args.choice = args.choice.deciding(deciding);
    if let Some(path) = &args.plot {
        crate::plot::check_path(path).map_err(report::usage)?;
    }
    // The bound from parameter uncertainty is that of the relation as written.
    let realise = if args.adaptive {
        if args.choice.realise() != Realise::Direct {
            report::note(
                "--adaptive evaluates the ARRs as written (--realise direct): their bounds \
                 from parameter uncertainty are derived for them",
            );
        }
        Realise::Direct
    } else {
        args.choice.realise()
    };
    // The expressions as `bgc MODEL --emit rust` and `bond_graph!` write them: which ARRs can
    // be integrated depends on the form they are written in, and the two must evaluate the
    // same residuals.
    let c = io::compile_with(
        &args.model,
        args.values.path(),
        Derive::Everything,
        Some(bondgraph_core::Limits::default()),
        (args.choice.set(), realise),
    )?;
    if c.residual_code_refused() {
        return Err(report::refused(format!(
            "{}: no ARRs to evaluate",
            c.file_name
        )));
    }
    let program = c.program();
    let names: Vec<String> = program.raw.values().map(|r| r.name.clone()).collect();
    let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    match program.copy_stability(&params) {
        Some(stability) if stability != Stability::Decays => {
            let simulated: Vec<&str> = (c.arrs.iter())
                .filter(|a| a.form == ResidualForm::Simulated)
                .map(|a| a.name.as_str())
                .collect();
            report::note(format!(
                "{} (simulated): {}",
                simulated.join(", "),
                stability.meaning()
            ));
        }
        _ => {}
    }
    let data_name = args.data.display().to_string();
    let shortest = args.window.unwrap_or(WINDOWS[0]);
    let layout = Layout::new(&names, &args.time, &args.columns)?;
    let data = Data::load(&args.data, &layout, shortest)?;
    let data = from(data, &data_name, args.from, shortest)?;
    let healthy = match &args.calibrate {
        Some(path) => {
            let columns = calibration_columns(&args.columns, &args.calibrate_columns);
            let layout = Layout::new(&names, &args.time, &columns)?;
            let name = path.display().to_string();
            let healthy = Data::load(path, &layout, shortest)?;
            Some((name.clone(), from(healthy, &name, args.from, shortest)?))
        }
        None => None,
    };
    let chosen = match (&args.calibration, &healthy) {
        (Some(path), _) => kept(&args, (&c, &program), path, &data)?,
        (None, Some((name, record))) => {
            calibrated(&args, &c, &program, params, &data, (name, record))?
        }
        (None, None) => Chosen::from_options(&args, &c, &program, params)?,
    };
    if let (Some(path), Some((name, record))) = (&args.save_calibration, &healthy) {
        let text = chosen.kept(&args, (&c, &program), name, record)?.write();
        io::write(Some(path.as_path()), &text)?;
    }
    let Chosen {
        params,
        estimator,
        window,
        integration,
        walks,
        levels,
        conditioning,
        cusum,
        combined,
        ranges,
        holds,
        ..
    } = chosen;
    let generator = |integration: &[Integration]| {
        let fit = Fit {
            step: data.step,
            estimator,
            integration: integration.to_vec(),
        };
        Generator::new(&c, &program, &params, &fit).map_err(report::usage)
    };
    if data.time.len() < window {
        return Err(report::refused(format!("{data_name}: {} rows: the estimator's window of {window} samples needs at least {window}",
            data.time.len())));
    }
    let singular_spans = match &conditioning {
        Some(conditioning) => {
            let pair = (generator(&integration)?, generator(&integration)?);
            let raw: Vec<&[f64]> = data.columns.iter().map(Vec::as_slice).collect();
            let (singular, first) =
                conditioning.undecided(&program, pair, &data.time, &raw, estimator);
            if let Some(first) = first {
                report::note(format!(
                    "{data_name}: it starts unsettled (signals the estimators' polynomials do \
                     not follow, a start-up): its first {first} rows, to {} s, have no \
                     threshold and raise no alarm",
                    io::seconds(data.time[first])
                ));
            }
            singular
        }
        None => Singular::default(),
    };
    let memories = (Fit {
        step: data.step,
        estimator,
        integration: integration.clone(),
    })
    .memories(&c.arrs);
    // A held residual is evaluated from the start: its onset test and its hold both read
    // that running integral, each over its own reach.
    let evaluated: Vec<Integration> = (integration.iter().zip(&holds))
        .map(|(&i, h)| if h.is_some() { Integration::Start } else { i })
        .collect();
    let mut holding: Vec<Option<Holding>> = (holds.iter().zip(&integration))
        .map(|(h, i)| h.map(|h| Holding::new(h, onset_samples(*i))))
        .collect();
    let mut generator = generator(&evaluated)?;
    let mut levels = levels;
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
    let mut sequential: Vec<Option<Cusum>> = cusum.iter().map(|c| c.map(|c| c.test())).collect();
    let rows: Vec<(&str, Vec<u32>)> = c
        .components
        .iter()
        .map(|(_, comp)| (comp.name.as_str(), marks(&comp.marks)))
        .collect();
    let n = c.arrs.len();
    let raw: Vec<&[f64]> = data.columns.iter().map(Vec::as_slice).collect();
    let (mut residuals, mut bounds) = (vec![0.0; n], vec![0.0; n]);
    let mut running = vec![0.0; n];
    let mut held = Vec::new();
    let mut outside = Outside::new(&ranges, &data);
    let signal_names = raw_names(&program);
    let mut now: Vec<Option<f64>> = vec![None; n];
    let mut on = vec![false; n];
    let mut drawn = Drawn::new(n, args.plot.is_some());
    // The roots the residuals read, by slot: a sample where one is not found is flagged.
    let roots: Vec<(usize, String)> = (program.slots.iter())
        .filter_map(|(h, s)| match s.quantity {
            bondgraph_core::Quantity::Root(r) => Some((h.index(), c.roots[r].name.clone())),
            _ => None,
        })
        .collect();
    let mut unsolved: std::collections::BTreeMap<usize, (usize, f64)> = Default::default();
    // Per residual, the estimates where it is not a number for another reason than a root.
    // (A residual that overflows is told apart from one that is not a number.)
    let mut singular: std::collections::BTreeMap<(usize, bool), (usize, f64)> = Default::default();
    // Per residual, the estimates where its threshold overflowed.
    let mut unbounded: std::collections::BTreeMap<usize, (usize, f64)> = Default::default();
    // The rows are computed here and written as text by a second thread, chunk by chunk:
    // writing numbers costs about what computing them does.
    let out = std::thread::scope(|scope| {
        let (send, receive) = std::sync::mpsc::sync_channel::<Chunk>(4);
        let rows = &rows;
        let sizes = !args.no_size;
        let flagged = ranges.iter().any(Option::is_some);
        let head = header(&c, (&holds, flagged), &roots, sizes);
        let signals = &signal_names;
        let roots = &roots;
        let writer = scope.spawn(move || {
            let mut out = head;
            let mut named = Named::remembering(memories);
            for chunk in receive {
                chunk.write(&mut out, (rows, signals), &mut named, roots, sizes);
            }
            (out, named)
        });
        let mut chunk = Chunk::default();
        let mut estimates = 0;
        generator.run(&data.time, &raw, args.adaptive, |e| {
            for (j, (&e_at, &e_unsolved)) in e.at().iter().zip(e.unsolved()).enumerate() {
                for (k, (r, b)) in residuals.iter_mut().zip(&mut bounds).enumerate() {
                    (*r, *b) = (e.residual(k)[j], e.bound(k)[j]);
                    running[k] = *r;
                    if let Some(h) = holding[k].as_mut() {
                        *r = h.onset(*r);
                    }
                }
                for (k, ((((now, on), alarm), walk), ((l, b), &r))) in (now.iter_mut())
                    .zip(&mut on)
                    .zip(&mut alarms)
                    .zip(&walks)
                    .zip(levels.iter().zip(&bounds).zip(&residuals))
                    .enumerate()
                {
                    // Where the relation is singular the noise decides it: no threshold.
                    let singular = singular_spans.contains(k, e_at);
                    let level = l.filter(|_| !singular);
                    let threshold =
                        level.map(|l| walk.map_or(l, |w| w.threshold(l, estimates)) + b);
                    // A bound that overflows (signals near the largest double) is no threshold.
                    *now = threshold.filter(|t| t.is_finite());
                    if threshold.is_some() && now.is_none() {
                        let at = io::tidy_time(e_at, data.step);
                        unbounded.entry(k).or_insert((0, at)).0 += 1;
                    }
                    // A residual that is not a number says nothing: no alarm, and its
                    // debounce goes on from where it was.
                    *on = match (alarm.as_mut(), *now) {
                        (Some(a), Some(l)) if r.is_finite() => a.update_with_level(r, l),
                        _ => false,
                    };
                    if let Some(test) = sequential[k].as_mut().filter(|_| !singular) {
                        *on |= test.update(r);
                    }
                    if let Some(h) = holding[k].as_mut() {
                        let onset = *on;
                        *on |= h.update(running[k], estimates, onset, now.is_some());
                    }
                }
                let at = io::tidy_time(e_at, data.step);
                for (k, r) in residuals.iter().enumerate() {
                    if !r.is_finite() && e_unsolved.is_none() {
                        let entry = singular.entry((k, r.is_infinite())).or_insert((0, at));
                        entry.0 += 1;
                    }
                }
                chunk.push(at, &residuals, &now, &on);
                held.clear();
                // Where a residual has no threshold (unsettled, singular), neither has its hold.
                for (h, level) in holding.iter().zip(&now) {
                    if let Some(h) = h {
                        let threshold = level.map_or(f64::NAN, |_| h.threshold());
                        held.extend([h.value(), threshold]);
                    }
                }
                chunk.held.extend_from_slice(&held);
                if flagged {
                    chunk.beyond.extend(outside.at(e_at));
                }
                chunk.unsolved.push(e_unsolved);
                if let Some(slot) = e_unsolved {
                    let entry = unsolved.entry(slot).or_insert((0, at));
                    entry.0 += 1;
                }
                estimates += 1;
                drawn.push(e_at, &residuals, &now, &on);
                if chunk.time.len() == CHUNK_ROWS {
                    // The writer stops only when this side has: it cannot have gone away.
                    let _ = send.send(std::mem::take(&mut chunk));
                }
            }
        });
        let _ = send.send(chunk);
        drop(send);
        writer.join().unwrap_or_default()
    });
    let (mut out, named) = out;
    named.report(&rows, &c);
    let ranked = named.ranked(&rows, &c);
    say_beyond(
        &program,
        &ranges,
        &data,
        ranked.as_ref().map(|r| r.0),
        &data_name,
    );
    if let Some((first, ranked)) = ranked.filter(|_| !args.no_size) {
        // The estimates at an instant read half a window ahead: the samples from the first
        // alarm's plus that on hold the fault.
        let lookahead = (window.saturating_sub(1) / 2) as f64 * data.step;
        // An intermittent fault is sized over its first alarm: a span past its end would
        // average the fault with the healthy samples after it. The alarm ends up to half a
        // window after the fault does, as it begins up to half a window before.
        let until = named.quiet.map(|q| q - lookahead);
        let known = size_fault(
            &args,
            &c,
            &program,
            (&params, &combined),
            &data,
            (first + lookahead, until, &ranked),
        )?;
        out = crate::size::fill(out, &known);
    }
    for (slot, (count, first)) in &unsolved {
        if let Some((_, name)) = roots.iter().find(|r| r.0 == *slot) {
            report::warn(format!("{data_name}: `{name}` has no root at {count} estimates (the first at t = {first}): the residuals that read it are empty cells there, and the `unsolved` column names it"));
        }
    }
    for ((k, overflow), (count, first)) in &singular {
        let why = if *overflow {
            "its value passes the largest number a double holds (about 1.8e308: signals too large \
             for their products and powers)"
        } else {
            "its relation is singular there (a division by a signal at zero, a law outside its \
             domain)"
        };
        report::warn(format!(
            "{data_name}: {} is not a finite number at {count} estimates (the first at t = {first}): \
             {why}; those cells are empty and raise no alarm",
            c.arrs[*k].name
        ));
    }
    for (k, (count, first)) in &unbounded {
        report::warn(format!(
            "{data_name}: {}'s threshold is not a finite number at {count} estimates (the first at \
             t = {first}): its bound from the parameters' uncertainties passes the largest number \
             a double holds; those cells are empty and raise no alarm",
            c.arrs[*k].name
        ));
    }
    for (k, spans) in singular_spans.spans.iter().enumerate() {
        if !spans.is_empty() {
            report::warn(format!(
                "{data_name}: {} is singular at {} (its sensitivity to the noise over {GAIN} \
                 times its median on the healthy record): no threshold and no alarm there",
                c.arrs[k].name,
                singular_spans.said(k)
            ));
        }
    }
    // The residuals first: a plot that cannot be drawn leaves them written.
    io::write(args.output.as_deref(), &out)?;
    if let Some(path) = &args.plot {
        drawn.draw(path, &c).map_err(report::usage)?;
    }
    Ok(())
}

/// Which raw signals lie outside what the healthy record covered, at each estimate's
/// sample: the samples are read in order, as the estimates come.
struct Outside<'a> {
    ranges: &'a [Option<Range>],
    data: &'a Data,
    next: usize,
    flags: Vec<bool>,
}

impl<'a> Outside<'a> {
    fn new(ranges: &'a [Option<Range>], data: &'a Data) -> Outside<'a> {
        Outside {
            ranges,
            data,
            next: 0,
            flags: vec![false; ranges.len()],
        }
    }

    /// Each raw signal's flag at the sample of the estimate at `t`.
    fn at(&mut self, t: f64) -> impl Iterator<Item = bool> + '_ {
        let time = &self.data.time;
        // Estimates fall on samples: the first sample not before `t`, to rounding.
        while self.next + 1 < time.len() && time[self.next] < t - 0.25 * self.data.step {
            self.next += 1;
        }
        for ((flag, range), column) in (self.flags.iter_mut())
            .zip(self.ranges)
            .zip(&self.data.columns)
        {
            let x = column.get(self.next).copied().unwrap_or(f64::NAN);
            *flag = range.is_some_and(|r| x.is_finite() && !r.holds(x));
        }
        self.flags.iter().copied()
    }
}

/// The onset window of a held residual, in samples: its integration's window.
fn onset_samples(integration: Integration) -> usize {
    match integration {
        Integration::Window(n) => n,
        Integration::Start => 1,
    }
}

/// The record from `--from` on (all of it without), with at least `window` rows left.
fn from(data: Data, name: &str, from: Option<f64>, window: usize) -> Result<Data, Failure> {
    let Some(t) = from else {
        return Ok(data);
    };
    if !t.is_finite() {
        return Err(report::usage(format!(
            "--from {t}: expected a time in seconds"
        )));
    }
    let first = data.time.partition_point(|&s| s < t);
    let left = data.time.len() - first;
    if left < window {
        return Err(report::refused(format!(
            "{name}: {left} rows from {} s on (--from): the estimator's window of {window} \
             samples needs at least {window}",
            io::seconds(t)
        )));
    }
    Ok(data.skip(first))
}

/// What the residuals are evaluated and decided with: chosen by `--calibrate`, kept in a
/// `--calibration` file, or given by the options.
struct Chosen {
    /// The model's parameter values (fitted, where calibration fits them).
    params: Vec<f64>,
    /// The signals' estimator.
    estimator: Estimator,
    /// Its window, in samples.
    window: usize,
    /// Each residual's integration (for those not integrated, unused).
    integration: Vec<Integration>,
    /// Each residual's noise walk, where its threshold grows with it.
    walks: Vec<Option<Walk>>,
    /// Each residual's threshold (in its walk's deviations where it has one).
    levels: Vec<Option<f64>>,
    /// The probability a healthy record as long as the calibration's crosses a threshold.
    crossing: f64,
    /// What tells where a record is singular, where calibration read it.
    conditioning: Option<Conditioning>,
    /// Each residual's CUSUM beside its threshold, where calibration made one.
    cusum: Vec<Option<CusumLevels>>,
    /// The parameters calibration's fit found determined only together (by place).
    combined: Vec<Vec<usize>>,
    /// Each raw signal's range on the healthy record, where calibration read it.
    ranges: Vec<Option<Range>>,
    /// Each integrated residual's hold, where calibration gave it one.
    holds: Vec<Option<Hold>>,
}

impl Chosen {
    /// What the options give, with no healthy record: the model's values, the default
    /// estimator and integration, the thresholds given.
    fn from_options(
        args: &ResidualArgs,
        c: &Compiled,
        program: &Program,
        params: Vec<f64>,
    ) -> Result<Chosen, Failure> {
        let kind = args.estimator.unwrap_or(EstimatorArg::SavitzkyGolay).kind();
        let window = args.window.unwrap_or(kind.default_window());
        Ok(Chosen {
            params,
            estimator: kind.over(window, degree(args, program)),
            window,
            integration: vec![args.integration_window.unwrap_or_default(); c.arrs.len()],
            walks: vec![None; c.arrs.len()],
            levels: thresholds(c, &args.thresholds)?,
            crossing: Walk::CROSSING,
            conditioning: None,
            cusum: vec![None; c.arrs.len()],
            combined: Vec::new(),
            ranges: Vec::new(),
            holds: vec![None; c.arrs.len()],
        })
    }

    /// The calibration file's contents for this choice.
    fn kept(
        &self,
        args: &ResidualArgs,
        (c, program): (&Compiled, &Program),
        name: &str,
        healthy: &Data,
    ) -> Result<Calibration, Failure> {
        let (text, model) = model_text(args)?;
        let integrated =
            (c.arrs.iter()).map(|a| matches!(a.realisation, Realisation::Integrated(_)));
        Ok(Calibration {
            model,
            hash: fnv1a(&text),
            residuals: args.choice.spelled(),
            healthy: (name.to_string(), healthy.time.len(), healthy.step),
            crossing: self.crossing,
            start_up: (self.conditioning.as_ref()).and_then(|c| c.start_up),
            estimator: self.estimator,
            params: (c.parameters.values().map(|p| p.name.clone()))
                .zip(self.params.iter().copied())
                .collect(),
            noise: match &self.conditioning {
                Some(conditioning) => (program.raw.values().map(|r| r.name.clone()))
                    .zip(conditioning.deviations.iter().copied())
                    .collect(),
                None => Vec::new(),
            },
            decisions: (c.arrs.iter().zip(integrated).enumerate())
                .map(|(k, (a, integrated))| Decision {
                    name: a.name.clone(),
                    integration: integrated.then_some(self.integration[k]),
                    threshold: self.levels[k],
                    walk: self.walks[k],
                    typical: (self.conditioning.as_ref()).and_then(|c| c.typical[k]),
                    cusum: self.cusum[k],
                    hold: self.holds[k],
                })
                .collect(),
            combined: (self.combined.iter())
                .map(|places| {
                    (places.iter())
                        .filter_map(|&k| c.parameters.values().nth(k).map(|p| p.name.clone()))
                        .collect()
                })
                .collect(),
            ranges: (program.raw.values().zip(&self.ranges))
                .filter_map(|(r, range)| Some((r.name.clone(), (*range)?)))
                .collect(),
        })
    }
}

/// The model's text as compiled (without a byte-order mark), which a calibration's hash is
/// of, and its name as given.
fn model_text(args: &ResidualArgs) -> Result<(Vec<u8>, String), Failure> {
    let (_, bytes) = io::read(&args.model)?;
    let text = String::from_utf8_lossy(&bytes);
    let text = bondgraph_core::without_bom(&text).as_bytes().to_vec();
    Ok((text, args.model.display().to_string()))
}

/// The degree of the Savitzky–Golay fits: `--degree`, or 3, or the highest derivative read.
fn degree(args: &ResidualArgs, program: &Program) -> u32 {
    args.degree.unwrap_or(program.top_order().max(3))
}

/// What a `--calibration` file keeps, checked against the model, the options and the record:
/// a calibration is for the model it was made on, its residuals and its step.
fn kept(
    args: &ResidualArgs,
    (c, program): (&Compiled, &Program),
    path: &std::path::Path,
    data: &Data,
) -> Result<Chosen, Failure> {
    let name = path.display().to_string();
    let (_, bytes) = io::read(path)?;
    let text = String::from_utf8(bytes)
        .map_err(|_| report::refused(format!("{name}: not text (UTF-8)")))?;
    let kept = Calibration::parse(&text).map_err(|e| report::refused(format!("{name}: {e}")))?;
    let (model, model_name) = model_text(args)?;
    let params: Vec<&str> = c.parameters.values().map(|p| p.name.as_str()).collect();
    let arrs: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
    let (choice, realise) = args.choice.spelled();
    if let Err(e) = kept.applies(&model, (&choice, &realise), &params, &arrs, data.step) {
        let hint = match e {
            Mismatch::Model(_) => format!(
                " ({model_name}); calibrate again with --calibrate HEALTHY --save-calibration \
                 {name}"
            ),
            _ => String::new(),
        };
        return Err(report::refused(format!("{name}: {e}{hint}")));
    }
    let params = kept.values();
    let estimator = kept.estimator;
    let window = window_of(estimator);
    // A threshold given on the command line is a level, and wins over the kept one.
    let given = thresholds(c, &args.thresholds)?;
    let mut walks: Vec<Option<Walk>> = kept.decisions.iter().map(|d| d.walk).collect();
    let levels = (given.iter().zip(&kept.decisions).zip(&mut walks))
        .map(|((g, d), walk)| match g {
            Some(level) => {
                *walk = None;
                Some(*level)
            }
            None => d.threshold,
        })
        .collect();
    report::note(format!(
        "{name}: the calibration made on {} ({} rows) for {}: thresholds a healthy record of \
         that length crosses with probability {}",
        kept.healthy.0, kept.healthy.1, kept.model, kept.crossing
    ));
    Ok(Chosen {
        params,
        estimator,
        window,
        integration: (kept.decisions.iter())
            .map(|d| d.integration.unwrap_or_default())
            .collect(),
        walks,
        levels,
        crossing: kept.crossing,
        conditioning: kept.conditioning(),
        cusum: kept.decisions.iter().map(|d| d.cusum).collect(),
        combined: kept.combined_places(),
        ranges: kept.ranges_for(&raw_names(program)),
        // A level given on the command line is the residual's only test.
        holds: (kept.decisions.iter().zip(&given))
            .map(|(d, g)| d.hold.filter(|_| g.is_none()))
            .collect(),
    })
}

/// `--calibrate`: the choices the interpreter's calibration makes on the healthy record
/// (see `bondgraph_interpreter::calibrate`), said on standard error.
fn calibrated(
    args: &ResidualArgs,
    c: &Compiled,
    program: &Program,
    params: Vec<f64>,
    data: &Data,
    (name, healthy): (&str, &Data),
) -> Result<Chosen, Failure> {
    if (healthy.step - data.step).abs() > STEP_TOLERANCE * data.step {
        return Err(report::refused(format!(
            "{name}: its step ({} s) is not the record's ({} s)",
            io::seconds(healthy.step),
            io::seconds(data.step)
        )));
    }
    if !(0.0..=f64::MAX).contains(&args.margin) {
        return Err(report::usage("--margin must be a non-negative number"));
    }
    let choices = Choices {
        estimator: args.estimator.map(EstimatorArg::kind),
        window: args.window,
        degree: degree(args, program),
        integration: args.integration_window,
        share: args.false_alarm_rate.share(),
        crossing: (args.false_alarm_rate).crossing(healthy.time.len() as f64 * healthy.step),
        margin: args.margin,
        keep_model: args.keep_model,
        thresholds: thresholds(c, &args.thresholds)?,
        cusum: args.cusum,
        within: args.within,
    };
    let samples = Samples {
        time: &healthy.time,
        columns: healthy.columns.iter().map(Vec::as_slice).collect(),
        step: healthy.step,
    };
    let chosen = calibrate(c, program, &params, &samples, data.step, &choices)
        .map_err(|e| report::usage(e.to_string()))?;
    for note in &chosen.notes {
        report::note(format!("{name}: {note}"));
    }
    Ok(Chosen {
        estimator: chosen.estimator,
        window: window_of(chosen.estimator),
        integration: chosen.integration,
        walks: chosen.walks,
        levels: chosen.levels,
        crossing: chosen.crossing,
        params: chosen.params,
        conditioning: chosen.conditioning,
        cusum: chosen.cusum,
        combined: chosen.combined,
        ranges: chosen.ranges,
        holds: chosen.holds,
    })
}

/// The program's raw signals' names, in its order.
fn raw_names(program: &Program) -> Vec<&str> {
    program.raw.values().map(|r| r.name.as_str()).collect()
}

/// Says where the record goes beyond what the healthy record covered, if it does.
fn say_beyond(
    program: &Program,
    ranges: &[Option<Range>],
    data: &Data,
    alarm: Option<f64>,
    name: &str,
) {
    let columns: Vec<&[f64]> = data.columns.iter().map(Vec::as_slice).collect();
    let found = bondgraph_interpreter::beyond(ranges, &columns);
    let names = raw_names(program);
    if let Some(text) = bondgraph_interpreter::beyond_said(&names, &found, &data.time, alarm) {
        report::note(format!("{name}: {text}"));
    }
}

/// The healthy record's column mapping: `--column`'s, with each signal `--calibrate-column`
/// names mapped as it says.
fn calibration_columns(columns: &[String], overrides: &[String]) -> Vec<String> {
    let signal = |m: &String| m.split_once('=').map(|(s, _)| s.trim().to_string());
    let replaced: Vec<Option<String>> = overrides.iter().map(signal).collect();
    (columns.iter())
        .filter(|m| signal(m).is_none_or(|s| !replaced.contains(&Some(s))))
        .chain(overrides)
        .cloned()
        .collect()
}

/// The fault's size from `first` (the first alarm's samples on), for each candidate of
/// `ranked`; with `--sizes`, the best one's followed to the record's end. The stretches of
/// the residual CSV's size columns.
fn size_fault(
    args: &ResidualArgs,
    c: &Compiled,
    program: &bondgraph_core::program::Program,
    (params, combined): (&[f64], &[Vec<usize>]),
    data: &Data,
    (first, until, ranked): (f64, Option<f64>, &[String]),
) -> Result<Vec<crate::size::Known>, Failure> {
    // A bank's sizes are fitted by its relations: a copy of the model run again at every
    // evaluation cost minutes on a 300-s record.
    let relations = bondgraph_interpreter::Relations::of(c, program);
    let columns: Vec<&[f64]> = data.columns.iter().map(Vec::as_slice).collect();
    let (c, program, columns) = match &relations {
        Some(r) => (&r.compiled, &r.program, r.columns(&columns)),
        None => (c, program, columns),
    };
    let sizing =
        bondgraph_interpreter::Sizing::new(c, program, params, &data.time, columns, data.step);
    let span = sizing.span(args.size_span);
    if span > args.size_span {
        report::note(format!(
            "the fault's size: --size-span {} s holds {} samples at this record's step ({} s): \
             fitted over {} s instead, the {} samples a size needs at least (twice its \
             estimator's window)",
            significant(args.size_span),
            (args.size_span / data.step).floor(),
            significant(data.step),
            significant(span),
            bondgraph_interpreter::SIZE_SAMPLES
        ));
    }
    let ended = until.map(|u| u - first);
    let (span, until) = match sizing.over(ended, span) {
        SizeOver::Brief(alarm) => {
            report::note(format!(
                "the fault's size: its first alarm ends {} s after it began, shorter than the \
                 {} samples a size needs: fitted over {} s from it, as a fault that persists \
                 (an intermittent fault that brief is averaged with what follows)",
                significant(alarm.max(0.0)),
                bondgraph_interpreter::SIZE_SAMPLES,
                significant(span),
            ));
            (span, None)
        }
        SizeOver::Episode(alarm) => {
            report::note(format!(
                "the fault's size: its first alarm ends {} s after it began, within --size-span \
                 {} s: fitted over {} s, the alarm's samples (an intermittent fault, sized \
                 over one of its episodes)",
                significant(alarm),
                significant(args.size_span),
                significant(alarm),
            ));
            (alarm, until)
        }
        SizeOver::Span => (span, until),
    };
    let end = (data.time.last().copied().unwrap_or(first)).min(until.unwrap_or(f64::INFINITY));
    let (sized, told) = sizing.told(ranked, first, span, end);
    if told > span {
        report::note(format!(
            "the fault's size: the best two candidates, or the best one's two parameters, fit \
             alike over {} s (the second's cost under {} times the best's): fitted over {} s, \
             the span doubled until they were told apart or it was {} times as long (a change \
             that shows in the plant's transients and one that shows in its statics, or a dead \
             zone's width and its slope, fit alike over a span much shorter than the plant's \
             time constants or a cycle of its motion)",
            significant(span),
            bondgraph_interpreter::TOLD,
            significant(told),
            1 << bondgraph_interpreter::DOUBLINGS
        ));
    }
    let span = told;
    crate::size::note(c, &sized, (params, combined), first, span);
    let Some(best) = sized.first() else {
        return Ok(Vec::new());
    };
    let mut followed = Vec::new();
    if let Some(path) = &args.sizes {
        followed = sizing.follow(best, first, span);
        crate::size::write_followed(path, &followed, params)?;
    }
    Ok(crate::size::known(best, first, span, &followed))
}

/// A row's marks as the runtime's sparse signatures hold them.
fn marks(marks: &[usize]) -> Vec<u32> {
    marks
        .iter()
        .map(|&k| u32::try_from(k).expect("fewer than 2^32 ARRs"))
        .collect()
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
                marks: &[],
            })
            .collect();
        crate::plot::draw(path, &self.time, &panels)
    }
}

/// Each ARR's fixed threshold, from `ARR=LEVEL` arguments.
fn thresholds(c: &Compiled, given: &[String]) -> Result<Vec<Option<f64>>, Failure> {
    let mut levels = vec![None; c.arrs.len()];
    for g in given {
        let parsed = g.split_once('=').and_then(|(name, level)| {
            let k = c.arrs.iter().position(|a| a.name == name.trim())?;
            let level: f64 =
                (level.trim().parse().ok()).filter(|l: &f64| l.is_finite() && *l >= 0.0)?;
            Some((k, level))
        });
        match parsed {
            Some((k, level)) => levels[k] = Some(level),
            None => {
                let names: Vec<&str> = c.arrs.iter().map(|a| a.name.as_str()).collect();
                return Err(report::usage(format!("--threshold `{g}`: expected ARR=LEVEL with ARR one of {} and LEVEL a finite non-negative number",
                    names.join(", "))));
            }
        }
    }
    Ok(levels)
}

fn header(
    c: &Compiled,
    (holds, flagged): (&[Option<Hold>], bool),
    roots: &[(usize, String)],
    sizes: bool,
) -> String {
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
    for (a, _) in c.arrs.iter().zip(holds).filter(|(_, h)| h.is_some()) {
        let _ = write!(h, ",hold_{0},hold_threshold_{0}", a.name);
    }
    h.push_str(",candidates,suspects,episode");
    if flagged {
        h.push_str(",beyond");
    }
    if !roots.is_empty() {
        h.push_str(",unsolved");
    }
    if sizes {
        h.push_str(",sized,size,size_half_width");
    }
    h.push('\n');
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
    /// Per row, each held residual's hold and its threshold.
    held: Vec<f64>,
    /// Per row where the ranges are known, each raw signal outside what the healthy record
    /// covered.
    beyond: Vec<bool>,
    /// Per row, when the model's ARRs read roots: the name of the first not found, if any.
    unsolved: Vec<Option<usize>>,
}

impl Chunk {
    fn push(&mut self, t: f64, residuals: &[f64], levels: &[Option<f64>], on: &[bool]) {
        self.time.push(t);
        self.residuals.extend(residuals);
        self.levels.extend(levels);
        self.on.extend(on);
    }

    /// Appends the rows as CSV, with the candidates and the suspects of each row's alarms.
    fn write(
        &self,
        out: &mut String,
        (rows, signals): (&[(&str, Vec<u32>)], &[&str]),
        named: &mut Named,
        roots: &[(usize, String)],
        sizes: bool,
    ) {
        let n = self.residuals.len() / self.time.len().max(1);
        let m = self.held.len() / self.time.len().max(1);
        let b = self.beyond.len() / self.time.len().max(1);
        for (k, &t) in self.time.iter().enumerate() {
            let span = k * n..(k + 1) * n;
            let on = &self.on[span.clone()];
            io::push_number(out, t);
            for &r in &self.residuals[span.clone()] {
                out.push(',');
                // Not a number: the cell is empty, and standard error says where and why.
                if r.is_finite() {
                    io::push_number(out, r);
                }
            }
            for l in &self.levels[span] {
                out.push(',');
                if let Some(l) = *l {
                    io::push_number(out, l);
                }
            }
            for &a in on {
                out.push_str(if a { ",1" } else { ",0" });
            }
            for &v in &self.held[k * m..(k + 1) * m] {
                out.push(',');
                if v.is_finite() {
                    io::push_number(out, v);
                }
            }
            named.cells(rows, t, on, out);
            if b > 0 {
                out.push(',');
                let outside = &self.beyond[k * b..(k + 1) * b];
                let mut first = true;
                for (name, _) in signals.iter().zip(outside).filter(|(_, &o)| o) {
                    if !first {
                        out.push(' ');
                    }
                    out.push_str(name);
                    first = false;
                }
            }
            if !roots.is_empty() {
                out.push(',');
                let unsolved = self.unsolved.get(k).copied().flatten();
                if let Some((_, name)) = unsolved.and_then(|s| roots.iter().find(|r| r.0 == s)) {
                    out.push_str(name);
                }
            }
            // Filled once the fault is sized (see `size::fill`).
            if sizes {
                out.push_str(",,,");
            }
            out.push('\n');
        }
    }
}

/// The samples without an alarm after which a fault's first alarm has ended, for its size:
/// those a size needs (a shorter lull, an onset test's flicker before the hold takes over,
/// is not the fault's end).
const QUIET: usize = bondgraph_interpreter::SIZE_SAMPLES;

/// The candidates and suspects cells of the last alarm pattern, and the episode's candidates
/// for the residuals seen in alarm so far: alarms change seldom, and naming them for every row
/// would cost more than the rest of the row.
#[derive(Default)]
struct Named {
    /// Each residual's memory in samples (see `Episode::remembering`).
    memory: Vec<usize>,
    alarms: Vec<bool>,
    cells: String,
    episode: Option<Episode>,
    /// When the episode started.
    first: Option<f64>,
    /// When its first alarm ended: the first estimate after it with none, of a stretch
    /// with none of at least `QUIET` samples; and the stretch under way.
    quiet: Option<f64>,
    quieting: Option<(f64, usize)>,
    seen: Vec<bool>,
    episode_cell: String,
}

impl Named {
    /// Names for residuals with these memories, in samples.
    fn remembering(memory: Vec<usize>) -> Named {
        Named {
            memory,
            ..Named::default()
        }
    }

    /// `,candidates,suspects,episode` for the alarms `on` at `t`.
    fn cells(&mut self, rows: &[(&str, Vec<u32>)], t: f64, on: &[bool], out: &mut String) {
        let fsm = || rows.iter().map(|(n, s)| (*n, Signature::new(on.len(), s)));
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
        let memory = &self.memory;
        let episode =
            (self.episode).get_or_insert_with(|| Episode::new(on.len()).remembering(memory));
        episode.push(on);
        if episode.started() {
            self.first.get_or_insert(t);
            if self.quiet.is_none() {
                self.quieting = match (on.contains(&true), self.quieting) {
                    (true, _) => None,
                    (false, None) => Some((t, 1)),
                    (false, Some((since, n))) => Some((since, n + 1)),
                };
                if let Some((since, QUIET..)) = self.quieting {
                    self.quiet = Some(since);
                }
            }
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
    /// When the episode started, and its candidate components, best ranked first: those
    /// whose signature is exactly the residuals seen in alarm, else those that explain every
    /// one of them, else all.
    fn ranked(&self, rows: &[(&str, Vec<u32>)], c: &Compiled) -> Option<(f64, Vec<String>)> {
        let (episode, first) = (self.episode.as_ref()?, self.first?);
        let fsm = (rows.iter()).map(|(n, s)| (*n, Signature::new(c.arrs.len(), s)));
        let ranked = episode.rank(fsm);
        let exact: Vec<_> = (ranked.iter())
            .filter(|r| r.unexplained == 0 && r.unseen == 0)
            .collect();
        let explaining: Vec<_> = ranked.iter().filter(|r| r.unexplained == 0).collect();
        let groups = if !exact.is_empty() {
            exact
        } else if !explaining.is_empty() {
            explaining
        } else {
            ranked.iter().collect()
        };
        let names = (groups.iter())
            .flat_map(|r| r.names.iter().map(|n| n.to_string()))
            .collect();
        Some((first, names))
    }

    fn report(&self, rows: &[(&str, Vec<u32>)], c: &Compiled) {
        let (Some(episode), Some(first)) = (&self.episode, self.first) else {
            return;
        };
        let shares: Vec<String> = (c.arrs.iter().enumerate())
            .zip(episode.shares().iter().zip(episode.alarmed()))
            .map(|((k, a), (s, all))| {
                let memory = self.memory.get(k).copied().unwrap_or(0);
                format!(
                    "{} {:.1} % ({:.1} % in alarms longer than its memory, {memory} samples)",
                    a.name,
                    100.0 * all,
                    100.0 * s
                )
            })
            .collect();
        report::note(format!(
            "alarms from {first} s on: {} of the samples since (seen in alarm from {} % in \
             alarms longer than its memory: one instant's disturbance reaches no further); \
             the components by how well a single fault of each explains them:",
            shares.join(", "),
            100.0 * Episode::SEEN
        ));
        let fsm = rows
            .iter()
            .map(|(n, s)| (*n, Signature::new(c.arrs.len(), s)));
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

#[cfg(test)]
mod tests {
    use super::calibration_columns;

    #[test]
    fn the_healthy_record_maps_the_overridden_signals_only() {
        let columns = ["tau=force_ctrl".to_string(), "y=speed".to_string()];
        let overrides = ["tau=force".to_string()];
        assert_eq!(
            calibration_columns(&columns, &overrides),
            ["y=speed", "tau=force"]
        );
        assert_eq!(calibration_columns(&columns, &[]), columns);
    }
}
