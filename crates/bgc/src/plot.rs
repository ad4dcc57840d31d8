//! `--plot FILE.svg`: signals and residuals drawn with plotters, one panel per series.
//!
//! Long records are reduced to the smallest and largest value of each of at most
//! [`MAX_POINTS`] buckets of time, so that a spike of one sample still shows and a file of
//! 10^6 samples still opens. Only SVG is written: a PNG needs fonts rasterized, which would
//! make the output depend on the fonts of the machine.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

/// Most points drawn per series.
const MAX_POINTS: usize = 4000;

/// Height of one panel, in pixels.
const PANEL: u32 = 220;

/// One panel: a named series over time, with what else to draw on it.
pub(crate) struct Panel<'a> {
    /// Its title.
    pub name: &'a str,
    /// The values, one per time.
    pub values: &'a [f64],
    /// A threshold on |value| at each time (drawn as ±), if any.
    pub threshold: Option<&'a [f64]>,
    /// Whether the alarm is on at each time (shaded), if any.
    pub alarm: Option<&'a [bool]>,
    /// Times marked by a vertical line: when the scenario's faults start.
    pub marks: &'a [f64],
}

/// Draws `panels` over `time` into the SVG file `path`, one under the other.
pub(crate) fn draw(path: &Path, time: &[f64], panels: &[Panel<'_>]) -> Result<(), String> {
    check_path(path)?;
    let failed = |e: &dyn std::fmt::Display| format!("`{}`: {e}", path.display());
    let svg = render(time, panels).map_err(|e| failed(&e))?;
    crate::output::replace(path, svg.as_bytes()).map_err(|e| failed(&e))
}

/// The SVG text of `panels` over `time`: drawn in memory, so that the file is written whole
/// or not at all, as every file bgc writes.
fn render(
    time: &[f64],
    panels: &[Panel<'_>],
) -> Result<String, DrawingAreaErrorKind<std::io::Error>> {
    let height = PANEL * panels.len().max(1) as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let areas = root.split_evenly((panels.len().max(1), 1));
        for (area, panel) in areas.iter().zip(panels) {
            draw_panel(area, time, panel)?;
        }
        root.present()?;
    }
    Ok(svg)
}

/// Whether a plot can be written at `path`: an `.svg` name in a directory that exists. Checked
/// before any work, so that a typo costs no run.
pub(crate) fn check_path(path: &Path) -> Result<(), String> {
    if path.extension().and_then(|e| e.to_str()) != Some("svg") {
        return Err(format!(
            "`{}`: plots are written as SVG only; name the file `.svg`",
            path.display()
        ));
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    if dir.is_some_and(|d| !d.is_dir()) {
        return Err(format!(
            "`{}`: the directory `{}` does not exist",
            path.display(),
            dir.map(|d| d.display().to_string()).unwrap_or_default()
        ));
    }
    Ok(())
}

type Result2 = Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    time: &[f64],
    panel: &Panel<'_>,
) -> Result2 {
    let (t0, t1) = (
        time.first().copied().unwrap_or(0.0),
        time.last().copied().unwrap_or(1.0),
    );
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let (low, high, clipped) = value_range(panel);
    let mesh = Mesh::new(low, high);
    let mut chart = ChartBuilder::on(area)
        .caption(caption(panel, clipped), ("sans-serif", 15))
        .margin(8)
        // Room for the last time label, centred on the right edge.
        .margin_right(28)
        // Room for the tick labels and, below them, `t [s]`.
        .x_label_area_size(44)
        .y_label_area_size(78)
        .build_cartesian_2d(t0..t1, mesh.low..mesh.high)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_labels(mesh.labels)
        .y_label_formatter(&|v| mesh.label(*v))
        .light_line_style(WHITE)
        .draw()?;
    let (low, high) = (mesh.low, mesh.high);
    for &at in panel.marks.iter().filter(|&&at| (t0..=t1).contains(&at)) {
        let style = BLACK.mix(0.6).stroke_width(1);
        chart.draw_series(std::iter::once(PathElement::new(
            [(at, low), (at, high)],
            style,
        )))?;
    }
    if let Some(alarm) = panel.alarm {
        let shade = RED.mix(0.15).filled();
        chart.draw_series(
            intervals(time, alarm)
                .into_iter()
                .map(|(a, b)| Rectangle::new([(a, low), (b, high)], shade)),
        )?;
    }
    // Values out of view are drawn at the edge, so that a clipped transient still shows.
    let clip = |v: f64| v.clamp(low, high);
    if let Some(th) = panel.threshold {
        let style = RED.stroke_width(1);
        let upper: Vec<f64> = th.iter().map(|&v| clip(v)).collect();
        let lower: Vec<f64> = th.iter().map(|&v| clip(-v)).collect();
        chart.draw_series(LineSeries::new(reduce(time, &upper), style))?;
        chart.draw_series(LineSeries::new(reduce(time, &lower), style))?;
    }
    let values: Vec<f64> = panel.values.iter().map(|&v| clip(v)).collect();
    chart.draw_series(LineSeries::new(reduce(time, &values), BLUE.stroke_width(1)))?;
    Ok(())
}

/// A panel's title: its name, the key to its colours where there is more than one series
/// (in the title, where it hides no data), whether any alarm was raised, and what is out of
/// view.
fn caption(panel: &Panel<'_>, clipped: Option<f64>) -> String {
    let mut out = panel.name.to_string();
    if panel.threshold.is_some() || panel.alarm.is_some() {
        out.push_str(" — residual (blue), ± threshold (red), alarm (shaded)");
    }
    if let Some(alarm) = panel.alarm {
        if !alarm.iter().any(|&a| a) {
            out.push_str(": no alarm");
        }
    }
    if let Some(extreme) = clipped {
        out.push_str(&format!(
            " (values up to {} drawn at the edge)",
            short(extreme)
        ));
    }
    out
}

/// The range a panel shows, and the largest |value| left out of it. A residual panel is
/// scaled to what it holds most of the time and to its threshold: a start-up transient of
/// ±100,000 would hide a residual of ±0.1 and its threshold; what lies beyond is drawn at
/// the edge and said in the title. Other panels show all their values.
fn value_range(panel: &Panel<'_>) -> (f64, f64, Option<f64>) {
    let finite: Vec<f64> = panel
        .values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let extreme = finite.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (mut low, mut high) = match panel.threshold {
        Some(_) => robust(&finite),
        None => (
            finite.iter().copied().fold(f64::INFINITY, f64::min),
            finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ),
    };
    if let Some(th) = panel.threshold {
        let top = th
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        // Past ten times its threshold a residual is in alarm whatever its value: what is
        // beyond is drawn at the edge.
        if top > 0.0 {
            (low, high) = (low.max(-10.0 * top), high.min(10.0 * top));
        }
        low = low.min(-top);
        high = high.max(top);
    }
    if !(low.is_finite() && high.is_finite()) {
        (low, high) = (-1.0, 1.0);
    }
    // A signal that does not move (a constant input) gets a range of its own size, so that
    // its axis has labels that differ (not nine times `12.000`).
    let pad = if high - low > 1e-9 * high.abs().max(low.abs()).max(1e-300) {
        (high - low) * 0.05
    } else {
        0.05 * high.abs().max(1.0)
    };
    let (low, high) = (low - pad, high + pad);
    let clipped = (extreme > high.abs().max(low.abs())).then_some(extreme);
    (low, high, clipped)
}

/// The range of the middle 98 % of `values`, widened by half again: what a residual holds
/// apart from its start-up and its largest spikes.
fn robust(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::INFINITY, f64::NEG_INFINITY);
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.01), at(0.99));
    let half = 0.25 * (hi - lo);
    (lo - half, hi + half)
}

/// The y axis: its range and labels, each written with the digits its spacing needs, so
/// that no two read the same (`0.0` three times for ticks 0.01 apart).
struct Mesh {
    low: f64,
    high: f64,
    labels: usize,
    digits: usize,
    scientific: bool,
}

impl Mesh {
    fn new(low: f64, high: f64) -> Mesh {
        let labels = 6;
        let step = (high - low) / labels as f64;
        let magnitude = high.abs().max(low.abs());
        let scientific = magnitude >= 1e5 || (magnitude > 0.0 && magnitude < 1e-3);
        let digits = if scientific {
            // Enough significant digits that ticks `step` apart differ.
            ((magnitude / step).log10().ceil().max(1.0) as usize).min(6)
        } else {
            ((-step.log10()).ceil().max(0.0) as usize + 1).min(9)
        };
        Mesh {
            low,
            high,
            labels,
            digits,
            scientific,
        }
    }

    fn label(&self, v: f64) -> String {
        // `-0.000` reads as a value of its own.
        let v = if v.abs() < (self.high - self.low) * 1e-12 {
            0.0
        } else {
            v
        };
        if self.scientific {
            format!("{v:.*e}", self.digits)
        } else {
            format!("{v:.*}", self.digits)
        }
    }
}

/// A number for a title, to 3 significant digits.
fn short(x: f64) -> String {
    format!("{x:.2e}")
}

/// The time intervals where `on` holds.
fn intervals(time: &[f64], on: &[bool]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut start = None;
    for (&t, &a) in time.iter().zip(on) {
        match (start, a) {
            (None, true) => start = Some(t),
            (Some(s), false) => {
                out.push((s, t));
                start = None;
            }
            _ => {}
        }
    }
    if let (Some(s), Some(&end)) = (start, time.last()) {
        out.push((s, end));
    }
    out
}

/// At most [`MAX_POINTS`] points: in each bucket of time, its smallest and largest values in
/// the order they come.
fn reduce(time: &[f64], values: &[f64]) -> Vec<(f64, f64)> {
    let n = time.len().min(values.len());
    if n <= MAX_POINTS {
        return time
            .iter()
            .copied()
            .zip(values.iter().copied())
            .take(n)
            .collect();
    }
    let buckets = MAX_POINTS / 2;
    let mut out = Vec::with_capacity(MAX_POINTS);
    for b in 0..buckets {
        let (from, to) = (
            b * n / buckets,
            ((b + 1) * n / buckets).max(b * n / buckets + 1),
        );
        let slice = &values[from..to.min(n)];
        let (mut lo, mut hi) = (0, 0);
        for (i, v) in slice.iter().enumerate() {
            if *v < slice[lo] {
                lo = i;
            }
            if *v > slice[hi] {
                hi = i;
            }
        }
        let (first, second) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push((time[from + first], values[from + first]));
        if second != first {
            out.push((time[from + second], values[from + second]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_series_keeps_its_spikes() {
        let time: Vec<f64> = (0..1_000_000).map(|k| k as f64 * 1e-3).collect();
        let mut values = vec![0.0; time.len()];
        values[123_457] = 5.0;
        let reduced = reduce(&time, &values);
        assert!(reduced.len() <= MAX_POINTS);
        assert!(reduced.contains(&(time[123_457], 5.0)));
    }

    /// A constant signal's panel has y labels that differ (it had nine times `12.000`).
    #[test]
    fn a_constant_signal_has_distinct_labels() {
        let dir = std::env::temp_dir().join(format!("bgc-plot-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("constant.svg");
        let time: Vec<f64> = (0..100).map(|k| f64::from(k) * 0.1).collect();
        let values = vec![12.0; time.len()];
        let panel = Panel {
            name: "U0",
            values: &values,
            threshold: None,
            alarm: None,
            marks: &[],
        };
        draw(&path, &time, &[panel]).expect("drawn");
        let svg = std::fs::read_to_string(&path).expect("svg");
        let labels: std::collections::BTreeSet<String> = svg
            .split("</text>")
            .filter_map(|s| s.rsplit('>').next())
            .map(str::trim)
            .filter(|s| s.parse::<f64>().is_ok_and(|v| v > 5.0 && v < 20.0))
            .map(str::to_string)
            .collect();
        assert!(labels.len() >= 3, "{labels:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The text of every `<text>` element of `svg`.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("</text>")
            .filter_map(|s| s.rsplit('>').next())
            .map(|s| s.trim().to_string())
            .collect()
    }

    /// A residual of ±0.1 under a start-up transient of ±100,000: the panel is scaled to
    /// the residual and its threshold, the transient is drawn at the edge and said in the
    /// title, the y labels all differ, the key is in the title (no legend box over the data),
    /// and a run without alarm says so.
    #[test]
    fn a_residual_panel_is_scaled_to_its_threshold_and_says_what_it_leaves_out() {
        let time: Vec<f64> = (0..2000).map(|k| f64::from(k) * 0.01).collect();
        let mut values: Vec<f64> = time.iter().map(|t| 0.1 * (3.0 * t).sin()).collect();
        values[..20].iter_mut().for_each(|v| *v = 1e5);
        let threshold = vec![0.2; time.len()];
        let alarm = vec![false; time.len()];
        let panel = Panel {
            name: "ARR1",
            values: &values,
            threshold: Some(&threshold),
            alarm: Some(&alarm),
            marks: &[],
        };
        let svg = render(&time, &[panel]).expect("drawn");
        let texts = texts(&svg);
        let title = texts
            .iter()
            .find(|t| t.starts_with("ARR1"))
            .expect("a title");
        assert!(title.contains("no alarm"), "{title}");
        assert!(
            title.contains("values up to 1.00e5 drawn at the edge"),
            "{title}"
        );
        assert!(title.contains("± threshold (red)"), "{title}");
        let labels: Vec<f64> = texts.iter().filter_map(|t| t.parse().ok()).collect();
        let (lo, hi) = labels
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(hi < 100.0 && lo > -1.0, "scaled to the residual: {texts:?}");
        let distinct: std::collections::BTreeSet<&String> =
            texts.iter().filter(|t| t.parse::<f64>().is_ok()).collect();
        let all = texts.iter().filter(|t| t.parse::<f64>().is_ok()).count();
        assert_eq!(distinct.len(), all, "a label repeats: {texts:?}");
        assert!(!svg.contains(">residual<"), "a legend box over the data");
    }

    #[test]
    fn alarm_intervals_run_from_first_to_last_sample_on() {
        let time = [0.0, 1.0, 2.0, 3.0, 4.0];
        let on = [false, true, true, false, true];
        assert_eq!(intervals(&time, &on), vec![(1.0, 3.0), (4.0, 4.0)]);
    }
}
