//! LaTeX: the ARRs in an `align` environment and the FSM as a `tabular`, as in the paper's
//! Table 2; with `standalone`, a whole document that compiles with pdflatex.

use std::fmt::Write as _;

use bondgraph_core::{Compiled, Printer};

use crate::names;

/// Characters of LaTeX source that fit on one line of the page, roughly: a long ARR is broken
/// between the terms of its top-level sum so that it stays within the margins.
const LINE: usize = 110;

/// The state equations, ARRs and FSM as LaTeX.
pub fn emit(c: &Compiled, standalone: bool) -> String {
    let mut out = String::new();
    if standalone {
        out.push_str("\\documentclass{article}\n\\usepackage{amsmath}\n\\usepackage[margin=2cm]{geometry}\n\\allowdisplaybreaks\n\\begin{document}\n");
        let _ = writeln!(out, "\\section*{{Model \\texttt{{{}}}}}", escape(&c.name));
    }
    let printer = Printer::new(&c.exprs, |s| names::latex(c, s));
    if let Some(space) = c.state_space.as_ref().filter(|s| !s.equations.is_empty()) {
        out.push_str("% State equations\n\\begin{align}\n");
        let lines: Vec<String> = space
            .equations
            .iter()
            .map(|(k, rhs)| {
                let lhs = names::latex_derivative(&c.states[*k].name, 1);
                broken(&format!("  {lhs} &= "), &printer.latex_terms(*rhs), "")
            })
            .collect();
        out.push_str(&lines.join(" \\\\\n"));
        out.push_str("\n\\end{align}\n");
    }
    if !c.arrs.is_empty() {
        out.push_str("% Analytical redundancy relations\n\\begin{align}\n");
        let lines: Vec<String> = c
            .arrs
            .iter()
            .map(|arr| {
                let head = format!("  \\mathrm{{{}}}:\\quad & ", arr.name);
                broken(&head, &printer.latex_terms(arr.expr), " = 0")
            })
            .collect();
        out.push_str(&lines.join(" \\\\\n"));
        out.push_str("\n\\end{align}\n");
        fsm(&mut out, c);
    } else {
        let why = if c.sensors.is_empty() {
            "the model has no detectors"
        } else {
            "no detector makes an equation redundant"
        };
        let _ = writeln!(out, "% No analytical redundancy relations: {why}.");
        if standalone {
            let _ = writeln!(out, "No analytical redundancy relations: {why}.");
        }
    }
    if standalone {
        out.push_str("\\end{document}\n");
    }
    out
}

/// One equation of an `align`, its terms packed into lines of about [`LINE`] characters;
/// only the last line is numbered.
fn broken(head: &str, terms: &[(bool, String)], tail: &str) -> String {
    let mut lines: Vec<String> = vec![String::new()];
    for (i, (plus, term)) in terms.iter().enumerate() {
        let sign = match (i, plus) {
            (0, true) => "",
            (0, false) => "-",
            (_, true) => " + ",
            (_, false) => " - ",
        };
        let current = lines.last_mut().map_or(0, |l| l.len());
        if current > 0 && current + term.len() > LINE {
            lines.push(String::new());
        }
        if let Some(line) = lines.last_mut() {
            line.push_str(sign);
            line.push_str(term);
        }
    }
    let mut out = String::from(head);
    for (i, line) in lines.iter().enumerate() {
        if i > 0 {
            out.push_str(" \\nonumber \\\\\n  & \\qquad ");
        }
        out.push_str(line.trim_start());
    }
    out.push_str(tail);
    out
}

fn fsm(out: &mut String, c: &Compiled) {
    let cols = "l".to_string() + &"c".repeat(2 + c.arrs.len());
    let _ = writeln!(
        out,
        "% Fault signature matrix\n\\begin{{tabular}}{{{cols}}}\n\\hline"
    );
    let mut header = "Component & $D_b$ & $I_b$".to_string();
    for arr in &c.arrs {
        let _ = write!(header, " & {}", escape(&arr.name));
    }
    let _ = writeln!(out, "{header} \\\\\n\\hline");
    for row in c.components.values() {
        let bit = |b: bool| if b { "1" } else { "0" };
        let mut line = format!(
            "{} ({}) & {} & {}",
            escape(&row.name),
            escape(row.kind.name()),
            bit(row.detectable),
            bit(row.isolable)
        );
        for s in row.signature(c.arrs.len()) {
            let _ = write!(line, " & {}", bit(s));
        }
        let _ = writeln!(out, "{line} \\\\");
    }
    out.push_str("\\hline\n\\end{tabular}\n");
}

/// Text safe in LaTeX's text mode.
fn escape(s: &str) -> String {
    s.replace('\\', "\\textbackslash{}")
        .replace('_', "\\_")
        .replace('&', "\\&")
        .replace('%', "\\%")
        .replace('#', "\\#")
        .replace('$', "\\$")
}
