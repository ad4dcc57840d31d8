//! LaTeX: the ARRs in an `align` environment and the FSM as a `tabular`, as in the paper's
//! Table 2; with `standalone`, a whole document that compiles with pdflatex.

use std::fmt::Write as _;

use bondgraph_core::analysis::Analysis;
use bondgraph_core::symbolic::Printer;

use crate::names;

/// The ARRs and FSM as LaTeX.
pub fn emit(a: &Analysis<'_>, standalone: bool) -> String {
    let m = a.model;
    let states = &a.state.states;
    let mut out = String::new();
    if standalone {
        out.push_str("\\documentclass{article}\n\\usepackage{amsmath}\n\\usepackage[margin=2cm]{geometry}\n\\allowdisplaybreaks\n\\begin{document}\n");
        let _ = writeln!(out, "\\section*{{Model \\texttt{{{}}}}}", escape(&m.name));
    }
    let printer = Printer::new(&a.state.pool, |l| names::latex(m, states, l));
    if !states.is_empty() {
        out.push_str("% State equations\n\\begin{align}\n");
        let lines: Vec<String> = states
            .iter()
            .map(|s| {
                format!(
                    "  {} &= {}",
                    names::latex_derivative(&s.name, 1),
                    printer.latex(s.rhs)
                )
            })
            .collect();
        out.push_str(&lines.join(" \\\\\n"));
        out.push_str("\n\\end{align}\n");
    }
    let printer = Printer::new(&a.diagnosis.causal.system.pool, |l| {
        names::latex(m, states, l)
    });
    out.push_str("% Analytical redundancy relations\n\\begin{align}\n");
    let lines: Vec<String> = a
        .diagnosis
        .arrs
        .iter()
        .map(|arr| {
            format!(
                "  \\mathrm{{{}}}:\\quad & {} = 0",
                arr.name,
                printer.latex(arr.residual)
            )
        })
        .collect();
    out.push_str(&lines.join(" \\\\\n"));
    out.push_str("\n\\end{align}\n");
    fsm(&mut out, a);
    if standalone {
        out.push_str("\\end{document}\n");
    }
    out
}

fn fsm(out: &mut String, a: &Analysis<'_>) {
    let f = &a.fsm;
    let cols = "l".to_string() + &"c".repeat(2 + f.residuals.len());
    let _ = writeln!(
        out,
        "% Fault signature matrix\n\\begin{{tabular}}{{{cols}}}\n\\hline"
    );
    let mut header = "Component & $D_b$ & $I_b$".to_string();
    for r in &f.residuals {
        let _ = write!(header, " & ${}_{{{}}}$", &r[..1], &r[1..]);
    }
    let _ = writeln!(out, "{header} \\\\\n\\hline");
    for row in &f.rows {
        let bit = |b: bool| if b { "1" } else { "0" };
        let mut line = format!(
            "{} ({}) & {} & {}",
            escape(&row.component.name),
            escape(row.component.kind.name()),
            bit(row.detectable),
            bit(row.isolable)
        );
        for s in row.signature(f.residuals.len()) {
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
