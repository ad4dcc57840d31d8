//! The machine contract, documented in the README. Written by hand so key order and number
//! formatting are fixed: the same model gives byte-identical JSON everywhere.

use std::fmt::Write as _;

use bondgraph_core::analysis::Analysis;
use bondgraph_core::graph::NodeKind;
use bondgraph_core::symbolic::Printer;

use crate::names;

/// A JSON string literal.
fn string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn number(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".to_string()
    }
}

fn list(items: impl IntoIterator<Item = String>) -> String {
    format!("[{}]", items.into_iter().collect::<Vec<_>>().join(", "))
}

/// The analysis as JSON.
pub fn emit(a: &Analysis<'_>) -> String {
    let m = a.model;
    let states = &a.state.states;
    let mut out = String::from("{\n");
    let _ = writeln!(out, "  \"model\": {},", string(&m.name));
    let params: Vec<String> = m
        .params
        .iter()
        .map(|p| format!("{}: {}", string(&p.name), number(p.value)))
        .collect();
    let _ = writeln!(out, "  \"parameters\": {{{}}},", params.join(", "));
    let _ = writeln!(
        out,
        "  \"inputs\": {},",
        list(m.inputs.iter().map(|i| string(&i.name)))
    );
    let sensors = m.nodes().filter_map(|n| match m.node(n).kind {
        NodeKind::Detector(k) => Some(format!(
            "{{\"name\": {}, \"kind\": {}}}",
            string(&m.node(n).name),
            string(k.name())
        )),
        _ => None,
    });
    let _ = writeln!(out, "  \"sensors\": {},", list(sensors));

    let printer = Printer::new(&a.state.pool, |l| names::text(m, states, l));
    let eqs: Vec<String> = states
        .iter()
        .map(|s| {
            format!(
                "\n    {{\"state\": {}, \"rhs\": {}}}",
                string(&s.name),
                string(&printer.text(s.rhs))
            )
        })
        .collect();
    let _ = writeln!(out, "  \"state_equations\": [{}\n  ],", eqs.join(","));

    let printer = Printer::new(&a.diagnosis.causal.system.pool, |l| {
        names::text(m, states, l)
    });
    let fsm = &a.fsm;
    let arrs: Vec<String> = a
        .diagnosis
        .arrs
        .iter()
        .enumerate()
        .map(|(i, arr)| {
            let components = fsm
                .rows
                .iter()
                .filter(|r| r.marks.binary_search(&i).is_ok())
                .map(|r| string(&r.component.name));
            format!(
                "\n    {{\"name\": {}, \"junction\": {}, \"sensor\": {}, \"expr\": {}, \"components\": {}}}",
                string(&arr.name),
                string(&m.node(arr.junction).name),
                arr.sensor.map_or("null".to_string(), |s| string(&m.node(s).name)),
                string(&printer.text(arr.residual)),
                list(components)
            )
        })
        .collect();
    let _ = writeln!(out, "  \"arrs\": [{}\n  ],", arrs.join(","));

    let rows: Vec<String> = fsm
        .rows
        .iter()
        .map(|r| {
            let c = &r.component;
            let bit = |b: bool| if b { "1" } else { "0" }.to_string();
            format!(
                "\n      {{\"component\": {}, \"kind\": {}, \"parameters\": {}, \"signals\": {}, \"signature\": {}, \"Db\": {}, \"Ib\": {}}}",
                string(&c.name),
                string(c.kind.name()),
                list(c.parameters.iter().map(|p| string(&m.params[p.0 as usize].name))),
                list(c.signals.iter().map(|s| string(s))),
                list(r.signature(fsm.residuals.len()).into_iter().map(bit)),
                bit(r.detectable),
                bit(r.isolable)
            )
        })
        .collect();
    let _ = writeln!(
        out,
        "  \"fsm\": {{\n    \"residuals\": {},\n    \"rows\": [{}\n    ]\n  }}",
        list(fsm.residuals.iter().map(|r| string(r))),
        rows.join(",")
    );
    out.push_str("}\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strings_and_numbers_are_valid_json() {
        assert_eq!(string("a\"b\\c\n\u{1}"), "\"a\\\"b\\\\c\\n\\u0001\"");
        assert_eq!(number(0.3), "0.3");
        assert_eq!(number(f64::NAN), "null");
        assert_eq!(number(1e-3), "0.001");
    }
}
