//! LaTeX: the ARRs in an `align` environment and the FSM as a `tabular`, as in the paper's
//! Table 2; with `standalone`, a whole document that compiles with pdflatex.

use std::fmt::Write as _;

use std::collections::HashMap;

use bondgraph_core::{
    Compiled, Expr, ExprId, Node, Pool, Printer, Realisation, ResidualForm, Symbol,
};

use crate::names;

/// Visible characters (see [`visible`]) of display math on one line of the page, 2 cm
/// margins: a long equation is broken between the terms of its top-level sum to stay within
/// them, and only a term wider than this is named in parts.
const PAGE_LINE: usize = 70;

/// A part shorter than this (visible characters) is never named: `\Phi_2 = \gamma \Phi_1`
/// costs a line and saves nothing.
const SHORTEST_NAMED: usize = 24;

/// Roughly how many characters `latex` shows on the page: command names count as one glyph
/// when they are letters or operators (`\gamma`, `\cdot`) or a thin space (`\,`), nothing
/// when they only lay out (`\mathrm`, `\frac`, `\left`); braces, subscript and superscript
/// marks count nothing.
fn visible(latex: &str) -> usize {
    const LAYOUT: [&str; 9] = [
        "mathrm", "frac", "left", "right", "dot", "ddot", "nonumber", "qquad", "quad",
    ];
    let mut count = 0;
    let mut chars = latex.chars().peekable();
    while let Some(ch) = chars.next() {
        match ch {
            '\\' => {
                let mut name = String::new();
                while let Some(&c) = chars.peek().filter(|c| c.is_ascii_alphabetic()) {
                    name.push(c);
                    chars.next();
                }
                if name.is_empty() {
                    // `\,` (a thin space, between factors: about a glyph at math sizes), `\{`.
                    if chars.next() == Some(',') {
                        count += 1;
                    }
                } else if !LAYOUT.contains(&name.as_str()) {
                    count += 1;
                }
            }
            '{' | '}' | '_' | '^' | ' ' => {}
            _ => count += 1,
        }
    }
    count
}

/// The state equations, ARRs and FSM as LaTeX.
pub fn emit(c: &Compiled, standalone: bool) -> String {
    let mut out = String::new();
    if standalone {
        out.push_str("\\documentclass{article}\n\\usepackage{amsmath}\n\\usepackage[margin=2cm]{geometry}\n\\allowdisplaybreaks\n\\begin{document}\n");
        let _ = writeln!(out, "\\section*{{Model \\texttt{{{}}}}}", escape(&c.name));
    }
    let mut writer = Writer::new(c);
    if let Some(space) = c.state_space.as_ref().filter(|s| !s.equations.is_empty()) {
        out.push_str("% State equations\n\\begin{align}\n");
        let mut lines: Vec<String> = space
            .equations
            .iter()
            .map(|(k, rhs)| {
                let lhs = names::latex_derivative(&c.states[*k].name, 1);
                writer.equation(&format!("  {lhs} &= "), *rhs, "")
            })
            .collect();
        // The loops' unknowns, each set implicitly by its equation.
        for l in &space.loops {
            let head = "  \\text{where}\\quad 0 &= ";
            let tail = format!("\\quad\\text{{sets }} {}", names::latex_name(&l.name));
            lines.push(writer.equation(head, l.residual, &tail));
        }
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
                let tail = match arr.form {
                    ResidualForm::Relation => " = 0",
                    ResidualForm::Simulated => {
                        " = 0\\quad\\text{(states of the model, simulated from its initial state)}"
                    }
                };
                let mut lines = vec![writer.equation(&head, arr.expr, tail)];
                if let Realisation::Integrated(i) = &arr.realisation {
                    // The residual is `F(t) - F(t0) + int A`: printed as the two parts, in
                    // calligraphic letters, which no model name is written in.
                    let head = format!(
                        "  \\text{{integrated}}\\quad & \\mathrm{{{}}} = \\dot{{\\mathcal{{F}}}} + \\mathcal{{A}},\\ \\mathcal{{F}} = ",
                        arr.name
                    );
                    lines.push(format!(
                        "{} \\nonumber",
                        writer.equation(&head, i.level, "")
                    ));
                    lines.push(format!(
                        "{} \\nonumber",
                        writer.equation("  & \\mathcal{A} = ", i.rate, "")
                    ));
                }
                for &a in &arr.auxiliaries {
                    let aux = &c.auxiliaries[a];
                    let head = format!(
                        "  \\text{{where}}\\quad & {} = ",
                        names::latex_name(&aux.name)
                    );
                    lines.push(writer.equation(&head, aux.definition(), ""));
                }
                for &k in &arr.roots {
                    let root = &c.roots[k];
                    let head = format!(
                        "  \\text{{where}}\\quad & {} \\text{{ solves }} ",
                        names::latex_name(&root.name)
                    );
                    lines.push(writer.equation(&head, root.residual, " = 0"));
                }
                lines.join(" \\\\\n")
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

/// A leaf of an equation being written: a name of the model, or a subexpression named
/// `\Phi_k` because it is too long for a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum Aux {
    Symbol(Symbol),
    Named(usize),
}

/// Writes the equations of a document, naming what does not fit on a line: a term longer
/// than [`PAGE_LINE`] has its long parts (at least [`SHORTEST_NAMED`] characters) replaced by `\Phi_k`, each
/// defined on lines of its own just before the equation that uses it.
struct Writer<'c> {
    c: &'c Compiled,
    pool: Pool<Aux>,
    named: usize,
    names: HashMap<ExprId<Aux>, ExprId<Aux>>,
}

impl<'c> Writer<'c> {
    fn new(c: &'c Compiled) -> Self {
        Writer {
            c,
            pool: Pool::default(),
            named: 0,
            names: HashMap::new(),
        }
    }

    fn latex(&self, e: ExprId<Aux>) -> String {
        let c = self.c;
        Printer::new(&self.pool, |l| match l {
            Aux::Symbol(s) => names::latex(c, s),
            Aux::Named(k) => format!("\\Phi_{{{k}}}"),
        })
        .latex(e)
    }

    fn terms(&self, e: ExprId<Aux>) -> Vec<(bool, String)> {
        let c = self.c;
        let printer = Printer::new(&self.pool, |l| match l {
            Aux::Symbol(s) => names::latex(c, s),
            Aux::Named(k) => format!("\\Phi_{{{k}}}"),
        });
        let terms = printer.terms(e);
        let alone = terms.len() == 1;
        terms
            .into_iter()
            .map(|(plus, t)| (plus, printer.latex_term(t, alone)))
            .collect()
    }

    /// The lines of one equation: the definitions it needs, then itself.
    fn equation(&mut self, head: &str, root: Expr, tail: &str) -> String {
        let e = self
            .pool
            .import_from(&self.c.exprs, root, |p, s| p.leaf(Aux::Symbol(s)));
        let mut defined = Vec::new();
        // Only a term wider than a line of the page is named in parts; the equation is
        // broken between its terms.
        let e = self.shorten_terms(e, &mut defined);
        let mut lines: Vec<String> = defined
            .iter()
            .map(|&(k, def)| {
                let head = format!("  \\Phi_{{{k}}} &= ");
                format!("{} \\nonumber", broken(&head, &self.terms(def), ""))
            })
            .collect();
        lines.push(broken(head, &self.terms(e), tail));
        lines.join(" \\\\\n")
    }

    /// `e` with each term of its top-level sum shortened to fit a line.
    fn shorten_terms(
        &mut self,
        e: ExprId<Aux>,
        defined: &mut Vec<(usize, ExprId<Aux>)>,
    ) -> ExprId<Aux> {
        let terms = Printer::new(&self.pool, |_| String::new()).terms(e);
        if terms.len() == 1 {
            return self.shorten(e, defined);
        }
        let mut out: Option<ExprId<Aux>> = None;
        for (plus, t) in terms {
            let t = self.shorten(t, defined);
            out = Some(match (out, plus) {
                (None, true) => t,
                (None, false) => self.pool.neg(t),
                (Some(a), true) => self.pool.add(a, t),
                (Some(a), false) => self.pool.sub(a, t),
            });
        }
        out.unwrap_or(e)
    }

    /// `e` with its longest parts named, one at a time, until it fits on a line.
    fn shorten(&mut self, e: ExprId<Aux>, defined: &mut Vec<(usize, ExprId<Aux>)>) -> ExprId<Aux> {
        let mut e = e;
        while visible(&self.latex(e)) > PAGE_LINE {
            let node = self.pool.node(e);
            let children: Vec<ExprId<Aux>> = match node {
                Node::Num(_) | Node::Leaf(_) => Vec::new(),
                Node::Neg(a) | Node::Call1(_, a) | Node::Int(a) => vec![a],
                Node::Binary(_, a, b) | Node::Call2(_, a, b) => vec![a, b],
            };
            let longest = children
                .iter()
                .copied()
                .filter(|&x| !matches!(self.pool.node(x), Node::Leaf(_) | Node::Num(_)))
                .map(|x| (visible(&self.latex(x)), x))
                .filter(|&(size, _)| size >= SHORTEST_NAMED)
                .max()
                .map(|(_, x)| x);
            let Some(longest) = longest else {
                return e;
            };
            let name = self.name(longest, defined);
            let map = |x: ExprId<Aux>| if x == longest { name } else { x };
            e = match node {
                Node::Num(_) | Node::Leaf(_) => e,
                Node::Neg(a) => self.pool.neg(map(a)),
                Node::Binary(op, a, b) => self.pool.binary(op, map(a), map(b)),
                Node::Call1(f, a) => self.pool.call(f, &[map(a)]),
                Node::Call2(f, a, b) => self.pool.call(f, &[map(a), map(b)]),
                Node::Int(a) => self.pool.int(map(a)),
            };
        }
        e
    }

    /// The name of `x`, defined (shortened in its turn) the first time it is needed; the
    /// same subexpression keeps its name through the document.
    fn name(&mut self, x: ExprId<Aux>, defined: &mut Vec<(usize, ExprId<Aux>)>) -> ExprId<Aux> {
        if let Some(&name) = self.names.get(&x) {
            return name;
        }
        let def = self.shorten_terms(x, defined);
        // Once its own parts are named, a short definition (`\Phi_{16} / k_2`) is written in
        // place rather than named in its turn.
        if visible(&self.latex(def)) < SHORTEST_NAMED {
            self.names.insert(x, def);
            return def;
        }
        self.named += 1;
        defined.push((self.named, def));
        let name = self.pool.leaf(Aux::Named(self.named));
        self.names.insert(x, name);
        name
    }
}

/// One equation of an `align`, its terms packed into lines of about [`PAGE_LINE`] visible characters;
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
        // The first line starts after the head (`ARR1:`, `F =`), the others after a quad.
        let indent = if lines.len() == 1 { visible(head) } else { 4 };
        let current = lines.last_mut().map_or(0, |l| visible(l));
        if current > 0 && indent + current + visible(term) > PAGE_LINE {
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

/// The FSM as the paper's Table 2, with each component's fault class: with these ARRs, and
/// with every residual the model's equations allow (a table note says which is which).
fn fsm(out: &mut String, c: &Compiled) {
    if c.arrs.len() > crate::text::DENSE_FSM_LIMIT {
        return fsm_rows(out, c);
    }
    let cols = "l".to_string() + &"c".repeat(4 + c.arrs.len());
    let _ = writeln!(
        out,
        "% Fault signature matrix\n\\begin{{tabular}}{{{cols}}}\n\\hline"
    );
    let mut header = "Component & $D_b$ & $I_b$".to_string();
    for arr in &c.arrs {
        let _ = write!(header, " & {}", escape(&arr.name));
    }
    header.push_str(" & Class & Class$^*$");
    let _ = writeln!(out, "{header} \\\\\n\\hline");
    let (selected, possible) = classes(c);
    let class = |k: &[Option<usize>], h: bondgraph_core::Handle<bondgraph_core::Component>| {
        k[h.index()].map_or("--".to_string(), |n| (n + 1).to_string())
    };
    for (h, row) in c.components.iter() {
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
        let _ = write!(line, " & {} & {}", class(&selected, h), class(&possible, h));
        let _ = writeln!(out, "{line} \\\\");
    }
    let _ = writeln!(
        out,
        "\\hline\n\\end{{tabular}}\n\\par\\smallskip{{\\footnotesize Class: the {} fault classes these ARRs tell apart; Class$^*$: the {} that residuals of the model's other equation sets could; --: undetectable.\\par}}",
        c.isolability.selected.classes.len(),
        c.isolability.possible.classes.len()
    );
}

/// The FSM of a model with more ARRs than [`crate::text::DENSE_FSM_LIMIT`]: each row with
/// the ARRs it shows in, so that the table grows with the model (a dense one of a
/// 50,000-stage chain was 6.4 GB of cells no one reads).
fn fsm_rows(out: &mut String, c: &Compiled) {
    let _ = writeln!(
        out,
        "% Fault signature matrix, by row: {} ARRs are too many for a column each\n\\begin{{tabular}}{{lcclcc}}\n\\hline\nComponent & $D_b$ & $I_b$ & ARRs & Class & Class$^*$ \\\\\n\\hline",
        c.arrs.len()
    );
    let bit = |b: bool| if b { "1" } else { "0" };
    let (selected, possible) = classes(c);
    let class = |k: &[Option<usize>], h: bondgraph_core::Handle<bondgraph_core::Component>| {
        k[h.index()].map_or("--".to_string(), |n| (n + 1).to_string())
    };
    for (h, row) in c.components.iter() {
        let arrs: Vec<String> = row.marks.iter().map(|&k| escape(&c.arrs[k].name)).collect();
        let _ = writeln!(
            out,
            "{} ({}) & {} & {} & {} & {} & {} \\\\",
            escape(&row.name),
            escape(row.kind.name()),
            bit(row.detectable),
            bit(row.isolable),
            if arrs.is_empty() {
                "--".to_string()
            } else {
                arrs.join(", ")
            },
            class(&selected, h),
            class(&possible, h)
        );
    }
    let _ = writeln!(
        out,
        "\\hline\n\\end{{tabular}}\n\\par\\smallskip{{\\footnotesize ARRs: those each component's fault shows in. Class: the {} fault classes these ARRs tell apart; Class$^*$: the {} that residuals of the model's other equation sets could; --: undetectable.\\par}}",
        c.isolability.selected.classes.len(),
        c.isolability.possible.classes.len()
    );
}

/// Each component's class with the chosen ARRs and with every residual, by handle index.
fn classes(c: &Compiled) -> (Vec<Option<usize>>, Vec<Option<usize>>) {
    let n = c.components.len();
    (
        c.isolability.selected.by_component(n),
        c.isolability.possible.by_component(n),
    )
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

#[cfg(test)]
mod tests {
    use super::*;

    fn latex_of(model: &str) -> String {
        let path = format!("{}/../../models/{model}.bg", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(path).expect("model");
        let c = bondgraph_core::compile(&text, model, &bondgraph_core::Options::default())
            .expect("valid")
            .compiled;
        emit(&c, false)
    }

    /// What a line of the page shows: layout commands, braces and scripts are not glyphs.
    #[test]
    fn visible_counts_glyphs_not_markup() {
        assert_eq!(visible(r"\mathrm{Re} \, p_{Lm}"), 2 + 1 + 3);
        assert_eq!(visible(r"\frac{a}{b}"), 2);
        assert_eq!(visible(r"\gamma"), 1);
    }

    /// The three tanks and the bench are written with few names, each for a part too long to
    /// share a line (the text of 2026-11 named 14 and 21 parts of them, some as short as
    /// `\Phi_2 = \gamma \Phi_1`), and no name stands for a short expression.
    #[test]
    fn only_long_parts_are_named() {
        for (model, most) in [("three_tank", 2), ("backlash_bench", 4)] {
            let latex = latex_of(model);
            let definitions: Vec<&str> = latex
                .lines()
                .filter(|l| l.trim_start().starts_with(r"\Phi_{"))
                .collect();
            assert!(definitions.len() <= most, "{model}: {definitions:#?}");
            for d in definitions {
                let body = d.split("&=").nth(1).unwrap_or_default();
                assert!(visible(body) >= SHORTEST_NAMED, "{model}: {d}");
            }
        }
    }
}
