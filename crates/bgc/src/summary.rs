//! What `bgc check` prints about a valid model.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use bondgraph_core::{Compiled, NodeClass};
use bondgraph_sim::Verification;

use bondgraph_codegen::text::WIDEST_COLUMN;

/// The summary of a model: counts by kind, then parameters and inputs.
pub(crate) fn check(c: &Compiled) -> String {
    let mut by_kind: BTreeMap<&str, usize> = BTreeMap::new();
    let (mut elements, mut junctions) = (0, 0);
    for node in c.graph.nodes.values() {
        match node.class {
            NodeClass::Element(kind) => {
                elements += 1;
                *by_kind.entry(kind).or_default() += 1;
            }
            NodeClass::Junction(_) => junctions += 1,
            NodeClass::Sensor(_) => {}
        }
    }
    let kinds: Vec<String> = by_kind.iter().map(|(k, n)| format!("{k} {n}")).collect();
    let mut out = String::new();
    let _ = writeln!(out, "model {}: valid", c.name);
    let _ = writeln!(out, "  elements   {elements:>6}  ({})", kinds.join(", "));
    let _ = writeln!(out, "  bonds      {:>6}", c.graph.bonds.len());
    let _ = writeln!(out, "  junctions  {junctions:>6}");
    let _ = writeln!(out, "  detectors  {:>6}", c.sensors.len());
    let _ = writeln!(out, "parameters ({})", c.parameters.len());
    let name_width = c
        .parameters
        .values()
        .map(|p| p.name.len())
        .max()
        .unwrap_or(0)
        .min(WIDEST_COLUMN);
    let values: Vec<String> = c.parameters.values().map(|p| p.value.to_string()).collect();
    let value_width = values
        .iter()
        .map(String::len)
        .max()
        .unwrap_or(0)
        .min(WIDEST_COLUMN);
    let units: Vec<String> = c
        .parameters
        .values()
        .map(|p| {
            p.unit
                .as_ref()
                .map(|u| format!("[{u}]"))
                .unwrap_or_default()
        })
        .collect();
    let unit_width = units
        .iter()
        .map(String::len)
        .max()
        .unwrap_or(0)
        .min(WIDEST_COLUMN);
    let known: Vec<String> = c.parameters.values().map(uncertainty).collect();
    let known_width = known.iter().map(String::len).max().unwrap_or(0);
    for (((p, value), unit), known) in c.parameters.values().zip(&values).zip(&units).zip(&known) {
        // The column of uncertainties is there only when a parameter has one.
        let known = match known_width {
            0 => String::new(),
            w => format!("{known:<w$}  "),
        };
        let line = format!(
            "  {:<name_width$} = {value:<value_width$}  {unit:<unit_width$}  {known}{}",
            p.name,
            p.description.as_deref().unwrap_or("")
        );
        let _ = writeln!(out, "{}", line.trim_end());
    }
    let inputs: Vec<&str> = c.inputs.values().map(|i| i.name.as_str()).collect();
    let _ = writeln!(out, "inputs ({}) {}", inputs.len(), inputs.join(" "));
    out
}

/// A parameter's `+- x%` as the model can write it: a share of its value, else the half-width
/// in its unit; empty when none is given.
fn uncertainty(p: &bondgraph_core::Parameter) -> String {
    // To 9 significant digits, as Display writes them (`5`, not `5.000000000000001`).
    let short = |x: f64| format!("{x:.8e}").parse::<f64>().unwrap_or(x);
    match p.uncertainty {
        Some(u) if p.value != 0.0 => format!("+- {}%", short(100.0 * u / p.value.abs())),
        Some(u) => format!("+- {}", short(u)),
        None => String::new(),
    }
}

/// A relative residual as the table prints it: `not finite` where the residual left the
/// numbers (it then shows a fault, and holds for nothing), never `inf` or `NaN`.
fn size(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3e}")
    } else {
        "not finite".to_string()
    }
}

/// The table `bgc verify` prints: each ARR on the healthy plant, then each FSM entry.
/// What the runs went through where `sign`, `abs`, `min` or `max` switch: an integrated
/// residual's level must not jump there (`jump`, relative to its size), and a model that
/// switches where no run went is said to be checked between its switches only.
fn crossings(out: &mut String, z: &bondgraph_sim::ZeroCrossings) {
    if z.arguments == 0 {
        return;
    }
    let arguments = format!(
        "{} argument{} of sign, abs, min or max",
        z.arguments,
        if z.arguments == 1 { "" } else { "s" }
    );
    if z.crossed == 0 {
        let _ = writeln!(
            out,
            "  note: no run crossed a zero of the {arguments}: the relations are checked between such crossings only"
        );
        return;
    }
    let _ = writeln!(
        out,
        "  (jump: an integrated residual's level across {} zero crossings of the {arguments}, relative to its size; {} of the runs had inputs of mean zero{})",
        z.crossed,
        z.reversing_runs,
        match z.stopped {
            0 => String::new(),
            n => format!(", {n} stopped where the model left the finite numbers"),
        }
    );
}

pub(crate) fn verification(c: &Compiled, v: &Verification) -> String {
    let verdict = |pass: bool| if pass { "pass" } else { "FAIL" };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "model {}: ARRs on the healthy plant (relative |residual|)",
        c.name
    );
    if v.scalings > 0 {
        let _ = writeln!(
            out,
            "  (initial states at scale {:e}, found: larger ones left the finite numbers; --state-scale sets it)",
            v.state_scale
        );
    }
    let switching = v.crossings.arguments > 0;
    for a in &v.arrs {
        let jump = match a.jump {
            Some(j) => format!("  jump {:>10}", size(j)),
            None if switching => format!("  {:15}", ""),
            None => String::new(),
        };
        let _ = writeln!(
            out,
            "  {:<8} {:>10}{jump}  {}",
            a.name,
            size(a.worst),
            verdict(a.pass)
        );
    }
    crossings(&mut out, &v.crossings);
    let width = c
        .components
        .values()
        .map(|k| k.name.len())
        .max()
        .unwrap_or(0)
        .clamp(9, WIDEST_COLUMN);
    let _ = writeln!(
        out,
        "FSM entries under a fault of each component (relative |residual|)"
    );
    for e in &v.entries {
        let _ = writeln!(
            out,
            "  {:<width$}  {:<8} {}  {:>10}  {}",
            c.components[e.component].name,
            c.arrs[e.arr].name,
            if e.marked { "1" } else { "0" },
            size(e.worst),
            verdict(e.pass)
        );
    }
    for h in &v.unchecked {
        let _ = writeln!(
            out,
            "  {:<width$}  not checked: no parameter of its own to fault in the plant",
            c.components[*h].name
        );
    }
    let failed =
        v.arrs.iter().filter(|a| !a.pass).count() + v.entries.iter().filter(|e| !e.pass).count();
    let _ = writeln!(
        out,
        "{}: {} ARRs, {} FSM entries checked, {failed} failed",
        if failed == 0 { "passed" } else { "FAILED" },
        v.arrs.len(),
        v.entries.len()
    );
    out
}
