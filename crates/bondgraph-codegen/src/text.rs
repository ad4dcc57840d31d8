//! The human summary: causality in both modes, state equations, ARRs, the FSM as a table.

use std::fmt::Write as _;

use bondgraph_core::{
    Arr, CausalityReport, Compiled, Mode, Printer, Realisation, ResidualForm, Setter,
    StorageCausality,
};

use crate::names;
use crate::shared::Shared;

/// The widest a column is padded to: a longer name is written whole, unaligned (a width past
/// 65,535 is beyond what `format!` pads, and aligning it would help no reader).
pub const WIDEST_COLUMN: usize = 200;

/// The causality report of every mode that was run (what `bgc causality` prints).
pub fn causality(c: &Compiled) -> String {
    let mut out = String::new();
    for r in &c.causality {
        report(&mut out, r);
    }
    out
}

/// `, where C1 and C2`: the conditions an inverse holds under, or nothing.
fn domain(conditions: &[String]) -> String {
    if conditions.is_empty() {
        String::new()
    } else {
        format!(", where {}", conditions.join(" and "))
    }
}

fn report(out: &mut String, r: &CausalityReport) {
    let (title, preferred) = match r.mode {
        Mode::Simulation => (
            "causality: preferred integral (simulation)",
            StorageCausality::Integral,
        ),
        Mode::Diagnosis => (
            "causality: preferred derivative, detectors inverted (diagnosis)",
            StorageCausality::Derivative,
        ),
    };
    let _ = writeln!(out, "{title}");
    for (name, s) in &r.storage {
        let word = match s {
            StorageCausality::Integral => "integral",
            StorageCausality::Derivative => "derivative",
            StorageCausality::Unassigned => "unassigned",
        };
        let note = if *s == preferred {
            ""
        } else {
            "  (not the preferred causality)"
        };
        let _ = writeln!(out, "  {name:<10} {word}{note}");
    }
    for (junction, setter) in &r.junctions {
        let what = match setter {
            Setter::Bond(n) => format!("bond {n}"),
            Setter::Detector(d) => format!("detector {d}"),
            Setter::Nothing => "nothing (unsolved)".to_string(),
        };
        let _ = writeln!(out, "  junction {junction} set by {what}");
    }
    for law in &r.inverted {
        let _ = writeln!(
            out,
            "  {:<10} law read the other way: {}{}",
            law.element,
            law.law,
            domain(&law.domain)
        );
    }
    for p in &r.problems {
        let _ = writeln!(out, "  problem: {p}");
    }
    for n in &r.notes {
        let _ = writeln!(out, "  note: {n}");
    }
    out.push('\n');
}

/// The state equations and the detector outputs, or why there are none.
pub fn state(c: &Compiled) -> String {
    let mut out = String::new();
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let _ = writeln!(out, "state equations");
    match &c.state_space {
        Some(space) => {
            if space.equations.is_empty() {
                let _ = writeln!(out, "  (none: the model stores no energy)");
            }
            for (k, rhs) in &space.equations {
                let _ = writeln!(out, "  der({}) = {}", c.states[*k].name, printer.text(*rhs));
            }
            for (s, e) in &space.outputs {
                let _ = writeln!(out, "  {} = {}", c.sensors[*s].name, printer.text(*e));
            }
            if !space.loops.is_empty() {
                let _ = writeln!(
                    out,
                    "  where, solved numerically (nonlinear algebraic loops):"
                );
            }
            for l in &space.loops {
                let _ = writeln!(
                    out,
                    "    0 = {}   ({} is {}, closed at `{}`)",
                    printer.text(l.residual),
                    l.name,
                    l.description,
                    l.element
                );
            }
        }
        None => {
            let _ = writeln!(
                out,
                "  not written: they cannot be derived (see the errors on standard error)"
            );
        }
    }
    out
}

/// The whole summary.
pub fn emit(c: &Compiled) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "model {}\n", c.name);
    out.push_str(&causality(c));
    out.push_str(&state(c));
    out.push('\n');
    arrs(&mut out, c);
    out.push('\n');
    fsm_table(&mut out, c);
    if !c.arrs.is_empty() {
        out.push('\n');
        isolability(&mut out, c);
    }
    out
}

/// Above this many components the isolability matrix is left to the classes, which say the
/// same (it is block-diagonal by class).
pub const DENSE_ISOLABILITY_LIMIT: usize = 30;

/// The fault classes with the ARRs and with every residual possible, then the matrix.
fn isolability(out: &mut String, c: &Compiled) {
    let i = &c.isolability;
    let _ = writeln!(
        out,
        "fault classes (single faults; the components of a class cannot be told apart)"
    );
    classes(out, c, &i.selected, "with these ARRs");
    if let Some(candidates) = &i.candidates {
        classes(
            out,
            c,
            candidates,
            "with every candidate residual bgc could write",
        );
    }
    classes(
        out,
        c,
        &i.possible,
        "with every residual the equations allow (structural)",
    );
    let most = i.bound.as_ref().unwrap_or(&i.possible);
    if most != &i.possible {
        classes(
            out,
            c,
            most,
            "with every residual the equations allow, counting the dependences bgc proved cancel",
        );
    }
    let reached = i.candidates.as_ref().unwrap_or(&i.selected).classes.len();
    if i.capped {
        let _ = writeln!(
            out,
            "  (more than {} classes: each class was left out of the part of the model around it, up to {} detectors of other classes; the residuals the structure allows over longer stretches are not derived)",
            bondgraph_core::MAX_DERIVATIONS,
            bondgraph_core::WINDOW_DETECTORS
        );
    } else if i.candidates.is_none() && reached < most.classes.len() {
        let _ = writeln!(
            out,
            "  (`--residuals best` looks for residuals that tell more classes apart)"
        );
    } else if reached < most.classes.len() && i.unrealised.is_empty() {
        let _ = writeln!(
            out,
            "  (telling the rest apart needs a residual bgc does not write: one that solves a law for a variable it holds nonlinearly, one that eliminates a component's parameter between its own equations (as p·q = F·v does a TF's ratio), or one longer than {} nodes written out)",
            bondgraph_core::MAX_CANDIDATE_SIZE
        );
    }
    for u in &i.unrealised {
        let names = |hs: &[bondgraph_core::Handle<bondgraph_core::Component>]| {
            hs.iter()
                .map(|&h| c.components[h].name.as_str())
                .collect::<Vec<_>>()
                .join(" ")
        };
        let _ = writeln!(
            out,
            "  not written: a residual without {} that would show {}",
            names(&u.without),
            names(&u.unseen)
        );
        if u.complete {
            let _ = writeln!(
                out,
                "    (bgc wrote as many residuals without {} as the equations allow, and the terms of {} cancel in every one; the structure counts a dependence the equations do not have)",
                names(&u.without),
                names(&u.cancelled)
            );
        } else if !u.cancelled.is_empty() {
            let _ = writeln!(
                out,
                "    ({}: a residual bgc derived without {} reads their equations, and their terms cancel in it; the structure counts a dependence that is not there)",
                names(&u.cancelled),
                names(&u.without)
            );
        }
        let unreached: Vec<_> = u
            .unseen
            .iter()
            .copied()
            .filter(|h| !u.cancelled.contains(h))
            .collect();
        for reason in &u.reasons {
            let _ = writeln!(out, "    ({reason})");
        }
        if u.reasons.is_empty() && !unreached.is_empty() {
            let _ = writeln!(
                out,
                "    ({}: bgc's derivation found no causal path to them; such a residual usually needs a law solved for a variable it holds nonlinearly, or a parameter eliminated between a component's own equations)",
                names(&unreached)
            );
        }
    }
    let n = c.components.len();
    if n == 0 || n > DENSE_ISOLABILITY_LIMIT {
        return;
    }
    let _ = writeln!(
        out,
        "isolability matrix (row told from column: 1 by these ARRs, + only by another residual, 0 never)"
    );
    let width = c
        .components
        .values()
        .map(|r| r.name.len())
        .max()
        .unwrap_or(0)
        .min(WIDEST_COLUMN);
    let handles: Vec<_> = c.components.iter().map(|(h, _)| h).collect();
    let mut header = format!("  {:<width$}", "");
    for h in &handles {
        let _ = write!(header, " {}", c.components[*h].name);
    }
    let _ = writeln!(out, "{}", header.trim_end());
    for &a in &handles {
        let mut line = format!("  {:<width$}", c.components[a].name);
        for &b in &handles {
            let cell = if i.selected.isolable(a, b) {
                "1"
            } else if most.isolable(a, b) {
                "+"
            } else {
                "0"
            };
            let w = c.components[b].name.len().min(WIDEST_COLUMN);
            let _ = write!(line, " {cell:>w$}");
        }
        let _ = writeln!(out, "{line}");
    }
}

fn classes(out: &mut String, c: &Compiled, k: &bondgraph_core::FaultClasses, title: &str) {
    let _ = writeln!(out, "  {title}: {} classes", k.classes.len());
    let names = |members: &[bondgraph_core::Handle<bondgraph_core::Component>]| {
        members
            .iter()
            .map(|&h| c.components[h].name.as_str())
            .collect::<Vec<_>>()
            .join(" ")
    };
    for (n, class) in k.classes.iter().enumerate() {
        let _ = writeln!(out, "    {:>3}  {}", n + 1, names(class));
    }
    if !k.undetectable.is_empty() {
        let _ = writeln!(out, "    undetectable: {}", names(&k.undetectable));
    }
}

/// How the residual generator evaluates `arr`, and the highest derivative it reads.
fn realisation(out: &mut String, write: &dyn Fn(bondgraph_core::Expr) -> String, arr: &Arr) {
    let order = arr.realised_order();
    match &arr.realisation {
        Realisation::Direct if arr.form == ResidualForm::Relation => {
            let _ = writeln!(
                out,
                "    realised as written: derivatives up to order {order}"
            );
        }
        Realisation::Direct => {}
        Realisation::Integrated(i) => {
            // `NAME.level` and `NAME.rate`: a dotted name is no model's (`F` was also the
            // input of `models/coulomb_friction.bg`).
            let name = &arr.name;
            let _ = writeln!(
                out,
                "    realised by integration, derivatives up to order {order}: the residual is \
                 {name}.level(t) - {name}.level(t0) + int({name}.rate) over [t0, t], where \
                 {name} = {name}.rate + der({name}.level) and\n      \
                 {name}.level = {}\n      {name}.rate = {}",
                write(i.level),
                write(i.rate)
            );
        }
    }
}

/// A repeated part of the ARRs this long or longer is written once, under a name.
const SHORTEST_SHARED: usize = 30;

fn arrs(out: &mut String, c: &Compiled) {
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let relations: Vec<_> = c.arrs.iter().map(|a| a.expr).collect();
    let mut realisations = Vec::new();
    for arr in &c.arrs {
        if let Realisation::Integrated(i) = &arr.realisation {
            realisations.extend([i.level, i.rate]);
        }
    }
    let shared = Shared::new(c, &relations, &realisations, SHORTEST_SHARED);
    let write = |e| shared.write(e);
    let _ = writeln!(out, "ARRs");
    let definitions = shared.definitions();
    if !definitions.is_empty() {
        let _ = writeln!(
            out,
            "  shared parts (each written once here, by name below):"
        );
        for d in definitions {
            let _ = writeln!(out, "    {d}");
        }
    }
    if !c.diagnosed {
        let _ = writeln!(
            out,
            "  not derived: the model could not be taken that far (see the errors on standard error)"
        );
    } else if c.sensors.is_empty() {
        let _ = writeln!(
            out,
            "  none: the model has no detectors (add `De NAME on JUNCTION` or `Df NAME on JUNCTION`)"
        );
    } else if c.arrs.is_empty() {
        let _ = writeln!(
            out,
            "  none: no detector makes an equation redundant (see the warnings on standard error)"
        );
    }
    let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
    let stability = (c.arrs.iter().any(|a| a.form == ResidualForm::Simulated))
        .then(|| c.program().copy_stability(&params))
        .flatten();
    for arr in &c.arrs {
        let sensor = arr.sensor.map_or("-", |s| c.sensors[s].name.as_str());
        let without = if arr.without.is_empty() {
            String::new()
        } else {
            let names: Vec<&str> = arr
                .without
                .iter()
                .map(|&h| c.components[h].name.as_str())
                .collect();
            format!(", without {}", names.join(" "))
        };
        let simulated = arr.form == ResidualForm::Simulated;
        let _ = writeln!(
            out,
            "  {} (junction {}, sensor {sensor}{without}{}):\n    {} = 0",
            arr.name,
            arr.junction,
            if simulated { ", simulated" } else { "" },
            write(arr.expr)
        );
        // A relation of the same detector (the bank's ARR beside its copy) reads no copy.
        let copy = (c.state_space.as_ref())
            .filter(|_| simulated)
            .and_then(|space| space.copies.iter().find(|k| Some(k.sensor) == arr.sensor));
        if let Some(copy) = copy {
            let imposed: Vec<&str> = (copy.imposed.iter())
                .map(|&s| c.sensors[s].name.as_str())
                .collect();
            let _ = writeln!(
                out,
                "    where the states are those of a copy of the part of the model that {} \
                 drive{} (each measurement in place of the state it measures) with the inputs \
                 as commanded, from rest:",
                imposed.join(", "),
                if imposed.len() == 1 { "s" } else { "" }
            );
            for (k, rhs) in &copy.equations {
                let _ = writeln!(
                    out,
                    "      der({}) = {}",
                    c.states[*k].name,
                    printer.text(*rhs)
                );
            }
            if let Some(stability) = stability {
                let _ = writeln!(out, "    ({})", stability.meaning());
            }
        } else if simulated {
            let _ = writeln!(
                out,
                "    where the states are those of a copy of the model: the state equations above, \
                 driven by the inputs as commanded, from the model's initial state"
            );
            if let Some(stability) = stability {
                let _ = writeln!(out, "    ({})", stability.meaning());
            }
        }
        realisation(out, &write, arr);
        for law in &arr.inverted {
            let _ = writeln!(
                out,
                "    reads the law of `{}` the other way: {}{}",
                law.element,
                law.law,
                domain(&law.domain)
            );
        }
        for &a in &arr.auxiliaries {
            let aux = &c.auxiliaries[a];
            let _ = writeln!(
                out,
                "    where {} = {}",
                aux.name,
                printer.text(aux.definition())
            );
        }
        for &k in &arr.roots {
            let root = &c.roots[k];
            let _ = writeln!(
                out,
                "    where {} is the root of {} = 0 (the law of `{}`, which has no closed-form inverse: solved numerically at each sample)",
                root.name,
                printer.text(root.residual),
                root.element
            );
        }
    }
}

/// Above this many ARRs the matrix is listed row by row (the ARRs each component shows in):
/// a dense table of a 10,000-stage chain is 64 million cells that no one reads.
pub const DENSE_FSM_LIMIT: usize = 30;

fn fsm_table(out: &mut String, c: &Compiled) {
    let _ = writeln!(out, "fault signature matrix");
    if c.arrs.is_empty() {
        let _ = writeln!(out, "  empty: no ARRs");
        return;
    }
    if c.arrs.len() > DENSE_FSM_LIMIT {
        fsm_rows(out, c);
        shared_parameters(out, c);
        return;
    }
    let width = c
        .components
        .values()
        .map(|r| r.name.len())
        .max()
        .unwrap_or(0)
        .clamp("component".len(), WIDEST_COLUMN);
    let columns: Vec<usize> = c.arrs.iter().map(|a| a.name.len().max(3)).collect();
    let mut header = format!("  {:<width$}  {:<5}  Db  Ib", "component", "kind");
    for (arr, w) in c.arrs.iter().zip(&columns) {
        let _ = write!(header, "  {:>w$}", arr.name);
    }
    let _ = writeln!(out, "{header}  parameters");
    for row in c.components.values() {
        let flag = |b: bool| if b { "1" } else { "0" };
        let mut line = format!(
            "  {:<width$}  {:<5}  {:>2}  {:>2}",
            row.name,
            row.kind.name(),
            flag(row.detectable),
            flag(row.isolable)
        );
        for (s, w) in row.signature(c.arrs.len()).into_iter().zip(&columns) {
            let _ = write!(line, "  {:>w$}", flag(s));
        }
        let params: Vec<&str> = row
            .parameters
            .iter()
            .map(|p| c.parameters[*p].name.as_str())
            .collect();
        let _ = writeln!(
            out,
            "{}",
            format!("{line}  {}", params.join(" ")).trim_end()
        );
    }
    shared_parameters(out, c);
}

/// The parameters several rows read, with the ARRs a change of each can show in.
fn shared_parameters(out: &mut String, c: &Compiled) {
    let shared = c.shared_parameters();
    if shared.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "shared parameters (a change of one faults every component that reads it: it can show in the ARRs of any of them)"
    );
    let width = shared
        .iter()
        .map(|s| c.parameters[s.parameter].name.len())
        .max()
        .unwrap_or(0)
        .min(WIDEST_COLUMN);
    for s in &shared {
        let components: Vec<&str> = s
            .components
            .iter()
            .map(|&h| c.components[h].name.as_str())
            .collect();
        let arrs: Vec<&str> = s.marks.iter().map(|&k| c.arrs[k].name.as_str()).collect();
        let _ = writeln!(
            out,
            "  {:<width$}  {}  ->  {}",
            c.parameters[s.parameter].name,
            components.join(" "),
            if arrs.is_empty() {
                "-".to_string()
            } else {
                arrs.join(" ")
            }
        );
    }
}

/// The matrix as one line per component: kind, Db, Ib, and the ARRs it shows in.
fn fsm_rows(out: &mut String, c: &Compiled) {
    let width = c
        .components
        .values()
        .map(|r| r.name.len())
        .max()
        .unwrap_or(0)
        .clamp("component".len(), WIDEST_COLUMN);
    let _ = writeln!(
        out,
        "  ({} ARRs: each component with the ARRs it shows in)",
        c.arrs.len()
    );
    let _ = writeln!(
        out,
        "  {:<width$}  {:<5}  Db  Ib  ARRs",
        "component", "kind"
    );
    for row in c.components.values() {
        let flag = |b: bool| if b { "1" } else { "0" };
        let arrs: Vec<&str> = row.marks.iter().map(|&k| c.arrs[k].name.as_str()).collect();
        let line = format!(
            "  {:<width$}  {:<5}  {:>2}  {:>2}  {}",
            row.name,
            row.kind.name(),
            flag(row.detectable),
            flag(row.isolable),
            if arrs.is_empty() {
                "-".to_string()
            } else {
                arrs.join(" ")
            }
        );
        let _ = writeln!(out, "{}", line.trim_end());
    }
}
