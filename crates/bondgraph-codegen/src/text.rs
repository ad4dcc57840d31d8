//! The human summary: causality in both modes, state equations, ARRs, the FSM as a table.

use std::fmt::Write as _;

use bondgraph_core::analysis::{Analysis, CausalityReport};
use bondgraph_core::causality::{Mode, StorageCausality, Strong};
use bondgraph_core::symbolic::Printer;

use crate::names;

/// The causality report of both modes (what `bgc causality` prints).
pub fn causality(analysis: &Analysis<'_>) -> String {
    let mut out = String::new();
    for mode in [Mode::Integral, Mode::Diagnosis] {
        report(&mut out, analysis, &analysis.causality(mode));
    }
    out
}

fn report(out: &mut String, a: &Analysis<'_>, r: &CausalityReport) {
    let m = a.model;
    let title = match r.mode {
        Mode::Integral => "causality: preferred integral (simulation)",
        Mode::Diagnosis => "causality: preferred derivative, detectors inverted (diagnosis)",
    };
    let _ = writeln!(out, "{title}");
    let preferred = match r.mode {
        Mode::Integral => StorageCausality::Integral,
        Mode::Diagnosis => StorageCausality::Derivative,
    };
    for (node, c) in &r.storage {
        let word = match c {
            StorageCausality::Integral => "integral",
            StorageCausality::Derivative => "derivative",
            StorageCausality::Unassigned => "unassigned",
        };
        let note = if *c == preferred {
            ""
        } else {
            "  (not the preferred causality)"
        };
        let _ = writeln!(out, "  {:<10} {word}{note}", m.node(*node).name);
    }
    for (junction, strong) in &r.strong {
        let what = match strong {
            Some(Strong::Bond(b)) => format!("bond {}", m.bond(*b).number),
            Some(Strong::Detector(d)) => format!("detector {}", m.node(*d).name),
            None => "nothing (unsolved)".to_string(),
        };
        let _ = writeln!(out, "  junction {} set by {what}", m.node(*junction).name);
    }
    for p in &r.problems {
        let _ = writeln!(out, "  problem: {p}");
    }
    out.push('\n');
}

/// The state equations and the detector outputs.
pub fn state(a: &Analysis<'_>) -> String {
    let m = a.model;
    let mut out = String::new();
    let states = &a.state.states;
    let printer = Printer::new(&a.state.pool, |l| names::text(m, states, l));
    let _ = writeln!(out, "state equations");
    for s in states {
        let _ = writeln!(out, "  der({}) = {}", s.name, printer.text(s.rhs));
    }
    for (sensor, e) in &a.state.outputs {
        let _ = writeln!(out, "  {} = {}", m.node(*sensor).name, printer.text(*e));
    }
    for p in &a.state.problems {
        let _ = writeln!(out, "  problem: {p}");
    }
    out
}

/// The whole summary.
pub fn emit(a: &Analysis<'_>) -> String {
    let m = a.model;
    let mut out = String::new();
    let _ = writeln!(out, "model {}\n", m.name);
    out.push_str(&causality(a));

    out.push_str(&state(a));
    out.push('\n');
    let states = &a.state.states;

    let printer = Printer::new(&a.diagnosis.causal.system.pool, |l| {
        names::text(m, states, l)
    });
    let _ = writeln!(out, "ARRs");
    for arr in &a.diagnosis.arrs {
        let sensor = arr.sensor.map_or("-", |s| m.node(s).name.as_str());
        let _ = writeln!(
            out,
            "  {} (junction {}, sensor {sensor}):\n    {} = 0",
            arr.name,
            m.node(arr.junction).name,
            printer.text(arr.residual)
        );
    }
    out.push('\n');
    fsm_table(&mut out, a);
    out
}

fn fsm_table(out: &mut String, a: &Analysis<'_>) {
    let fsm = &a.fsm;
    let _ = writeln!(out, "fault signature matrix");
    let width = fsm
        .rows
        .iter()
        .map(|r| r.component.name.len())
        .max()
        .unwrap_or(0)
        .max("component".len());
    let mut header = format!("  {:<width$}  {:<5}  Db  Ib", "component", "kind");
    for r in &fsm.residuals {
        let _ = write!(header, "  {r:>3}");
    }
    let _ = writeln!(out, "{header}  parameters");
    for row in &fsm.rows {
        let flag = |b: bool| if b { "1" } else { "0" };
        let mut line = format!(
            "  {:<width$}  {:<5}  {:>2}  {:>2}",
            row.component.name,
            row.component.kind.name(),
            flag(row.detectable),
            flag(row.isolable)
        );
        for s in row.signature(fsm.residuals.len()) {
            let _ = write!(line, "  {:>3}", flag(s));
        }
        let params: Vec<&str> = row
            .component
            .parameters
            .iter()
            .map(|p| a.model.params[p.0 as usize].name.as_str())
            .collect();
        let _ = writeln!(
            out,
            "{}",
            format!("{line}  {}", params.join(" ")).trim_end()
        );
    }
}
