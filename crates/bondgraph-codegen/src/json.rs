//! The machine contract, documented in the README. Written by hand so key order and number
//! formatting are fixed: the same model gives byte-identical JSON everywhere.

use std::fmt::Write as _;

use bondgraph_core::diagnostic::Severity;
use bondgraph_core::{
    Compiled, Component, FaultClasses, Handle, Printer, Realisation, ResidualForm, ResidualSet,
    Signal, SignalUse,
};

use crate::names;
use crate::text::DENSE_FSM_LIMIT;

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

/// How the fault signature matrix is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FsmForm {
    /// Dense up to [`DENSE_FSM_LIMIT`] ARRs, sparse above: see [`FsmForm::resolve`].
    #[default]
    Auto,
    /// Each row's `signature`: one 0 or 1 per ARR.
    Dense,
    /// Each row's `arrs`: the names of the ARRs it shows in (for models with many ARRs:
    /// the dense matrix of a 10,000-stage chain is most of a 203 MB file, and at 50,000
    /// stages it does not fit in memory).
    Sparse,
}

impl FsmForm {
    /// The form `c`'s FSM is written in: [`FsmForm::Auto`] is dense up to
    /// [`DENSE_FSM_LIMIT`] ARRs, sparse above, so that the file grows with the model, not with
    /// its square.
    pub fn resolve(self, c: &Compiled) -> FsmForm {
        match self {
            FsmForm::Auto if c.arrs.len() > DENSE_FSM_LIMIT => FsmForm::Sparse,
            FsmForm::Auto => FsmForm::Dense,
            other => other,
        }
    }
}

/// The product as JSON, with the FSM dense up to [`DENSE_FSM_LIMIT`] ARRs, sparse above.
pub fn emit(c: &Compiled) -> String {
    emit_with(c, FsmForm::Auto)
}

/// The product as JSON, with the FSM in the form asked for.
pub fn emit_with(c: &Compiled, form: FsmForm) -> String {
    let form = form.resolve(c);
    let mut out = String::from("{\n");
    let _ = writeln!(out, "  \"model\": {},", string(&c.name));
    let params: Vec<String> = c
        .parameters
        .values()
        .map(|p| format!("{}: {}", string(&p.name), number(p.value)))
        .collect();
    let _ = writeln!(out, "  \"parameters\": {{{}}},", params.join(", "));
    let uncertain: Vec<String> = c
        .parameters
        .values()
        .filter_map(|p| Some(format!("{}: {}", string(&p.name), number(p.uncertainty?))))
        .collect();
    let _ = writeln!(out, "  \"uncertainties\": {{{}}},", uncertain.join(", "));
    // The parameters that stand for a detector's or a source's fault (`with`).
    let carried: Vec<String> = (c.parameters.values())
        .filter_map(|p| {
            let f = p.carried.as_ref()?;
            Some(format!(
                "{}: {{\"fault\": {}, \"by\": {}, \"sensor\": {}}}",
                string(&p.name),
                string(f.fault.name()),
                string(&f.by),
                f.sensor
            ))
        })
        .collect();
    let _ = writeln!(out, "  \"carried\": {{{}}},", carried.join(", "));
    let _ = writeln!(
        out,
        "  \"inputs\": {},",
        list(c.inputs.values().map(|i| string(&i.name)))
    );
    let sensors = c.sensors.values().map(|s| {
        format!(
            "{{\"name\": {}, \"kind\": {}}}",
            string(&s.name),
            string(s.kind.name())
        )
    });
    let _ = writeln!(out, "  \"sensors\": {},", list(sensors));
    state_space(&mut out, c);
    arrs(&mut out, c);
    fsm(&mut out, c, form);
    isolability(&mut out, c);
    diagnostics(&mut out, c);
    out.push_str("}\n");
    out
}

fn state_space(out: &mut String, c: &Compiled) {
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let Some(space) = &c.state_space else {
        out.push_str(
            "  \"state_equations\": null,\n  \"outputs\": null,\n  \"algebraic_loops\": null,\n",
        );
        return;
    };
    let eqs: Vec<String> = space
        .equations
        .iter()
        .map(|(k, rhs)| {
            format!(
                "\n    {{\"state\": {}, \"rhs\": {}}}",
                string(&c.states[*k].name),
                string(&printer.text(*rhs))
            )
        })
        .collect();
    let _ = writeln!(out, "  \"state_equations\": [{}\n  ],", eqs.join(","));
    let outputs: Vec<String> = space
        .outputs
        .iter()
        .map(|(s, e)| {
            format!(
                "\n    {{\"sensor\": {}, \"expr\": {}}}",
                string(&c.sensors[*s].name),
                string(&printer.text(*e))
            )
        })
        .collect();
    let _ = writeln!(out, "  \"outputs\": [{}\n  ],", outputs.join(","));
    let loops: Vec<String> = space
        .loops
        .iter()
        .map(|l| {
            format!(
                "\n    {{\"name\": {}, \"description\": {}, \"element\": {}, \"residual\": {}}}",
                string(&l.name),
                string(&l.description),
                string(&l.element),
                string(&printer.text(l.residual))
            )
        })
        .collect();
    let _ = writeln!(out, "  \"algebraic_loops\": [{}\n  ],", loops.join(","));
}

/// What an expression reads, as JSON: each signal's derivative orders and integral.
fn reads_list(c: &Compiled, reads: &[SignalUse]) -> String {
    list(reads.iter().map(|r| {
        let name = match r.signal {
            Signal::Input(u) => &c.inputs[u].name,
            Signal::Sensor(s) => &c.sensors[s].name,
        };
        format!(
            "{{\"signal\": {}, \"orders\": {}, \"integral\": {}}}",
            string(name),
            list(r.orders.iter().map(u32::to_string)),
            r.integral
        )
    }))
}

fn arrs(out: &mut String, c: &Compiled) {
    let printer = Printer::new(&c.exprs, |s| names::text(c, s));
    let arrs: Vec<String> = c
        .arrs
        .iter()
        .map(|arr| {
            let components = arr.components.iter().map(|h| string(&c.components[*h].name));
            let reads = reads_list(c, &arr.reads);
            let realisation = match &arr.realisation {
                Realisation::Direct => format!(
                    "{{\"kind\": \"direct\", \"order\": {}}}",
                    arr.realised_order()
                ),
                Realisation::Integrated(i) => format!(
                    "{{\"kind\": \"integrated\", \"order\": {}, \"level\": {}, \"rate\": {}, \"reads\": {}}}",
                    arr.realised_order(),
                    string(&printer.text(i.level)),
                    string(&printer.text(i.rate)),
                    reads_list(c, &i.reads)
                ),
            };
            let auxiliaries = arr.auxiliaries.iter().map(|&a| {
                let aux = &c.auxiliaries[a];
                format!(
                    "{{\"name\": {}, \"expr\": {}}}",
                    string(&aux.name),
                    string(&printer.text(aux.definition()))
                )
            });
            let roots = arr.roots.iter().map(|&k| {
                let root = &c.roots[k];
                format!(
                    "{{\"name\": {}, \"element\": {}, \"residual\": {}, \"slope\": {}}}",
                    string(&root.name),
                    string(&root.element),
                    string(&printer.text(root.residual)),
                    string(&printer.text(root.slope))
                )
            });
            format!(
                "\n    {{\"name\": {}, \"junction\": {}, \"sensor\": {}, \"form\": {}, \"expr\": {}, \"auxiliaries\": {}, \"roots\": {}, \"components\": {}, \"without\": {}, \"reads\": {}, \"realisation\": {}, \"sensitivities\": {}, \"inverted\": {}}}",
                string(&arr.name),
                string(&arr.junction),
                arr.sensor.map_or("null".to_string(), |s| string(&c.sensors[s].name)),
                string(match arr.form {
                    ResidualForm::Relation => "relation",
                    ResidualForm::Simulated => "simulated",
                }),
                string(&printer.text(arr.expr)),
                list(auxiliaries),
                list(roots),
                list(components),
                list(arr.without.iter().map(|h| string(&c.components[*h].name))),
                reads,
                realisation,
                arr.sensitivities.as_ref().map_or("null".to_string(), |s| {
                    let entries: Vec<String> = s
                        .iter()
                        .map(|&(p, e)| format!("{}: {}", string(&c.parameters[p].name), string(&printer.text(e))))
                        .collect();
                    format!("{{{}}}", entries.join(", "))
                }),
                list(arr.inverted.iter().map(|law| format!(
                    "{{\"element\": {}, \"law\": {}, \"domain\": {}}}",
                    string(&law.element),
                    string(&law.law),
                    list(law.domain.iter().map(|d| string(d)))
                )))
            )
        })
        .collect();
    let _ = writeln!(out, "  \"arrs\": [{}\n  ],", arrs.join(","));
}

fn fsm(out: &mut String, c: &Compiled, form: FsmForm) {
    let bit = |b: bool| if b { "1" } else { "0" }.to_string();
    let rows: Vec<String> = c
        .components
        .values()
        .map(|r| {
            let marks = match form {
                FsmForm::Dense | FsmForm::Auto => format!(
                    "\"signature\": {}",
                    list(r.signature(c.arrs.len()).into_iter().map(bit))
                ),
                FsmForm::Sparse => format!(
                    "\"arrs\": {}",
                    list(r.marks.iter().map(|&k| string(&c.arrs[k].name)))
                ),
            };
            format!(
                "\n      {{\"component\": {}, \"kind\": {}, \"parameters\": {}, \"signals\": {}, {marks}, \"Db\": {}, \"Ib\": {}}}",
                string(&r.name),
                string(r.kind.name()),
                list(r.parameters.iter().map(|p| string(&c.parameters[*p].name))),
                list(r.signals.iter().map(|s| string(s))),
                bit(r.detectable),
                bit(r.isolable)
            )
        })
        .collect();
    let shared = list(c.shared_parameters().iter().map(|s| {
        format!(
            "{{\"parameter\": {}, \"components\": {}, \"arrs\": {}}}",
            string(&c.parameters[s.parameter].name),
            list(s.components.iter().map(|&h| string(&c.components[h].name))),
            list(s.marks.iter().map(|&k| string(&c.arrs[k].name)))
        )
    }));
    let _ = writeln!(
        out,
        "  \"fsm\": {{\n    \"residuals\": {},\n    \"rows\": [{}\n    ],\n    \"shared\": {}\n  }},",
        list(c.arrs.iter().map(|a| string(&a.name))),
        rows.join(","),
        shared
    );
}

/// The fault classes with the ARRs (`selected`) and with every residual possible
/// (`possible`); the isolability matrix follows from them and is not written.
fn isolability(out: &mut String, c: &Compiled) {
    let classes = |k: &FaultClasses| {
        let names = |members: &[Handle<Component>]| {
            list(members.iter().map(|&h| string(&c.components[h].name)))
        };
        format!(
            "{{\"classes\": {}, \"undetectable\": {}}}",
            list(k.classes.iter().map(|class| names(class))),
            names(&k.undetectable)
        )
    };
    let set = match c.isolability.residuals {
        ResidualSet::PerSensor => "per-sensor",
        ResidualSet::Best => "best",
        ResidualSet::All => "all",
        ResidualSet::Simulated => "simulated",
        ResidualSet::Partial => "partial",
        ResidualSet::Bank => "bank",
    };
    let _ = writeln!(
        out,
        "  \"isolability\": {{\"residuals\": {}, \"selected\": {}, \"candidates\": {}, \"possible\": {}, \"bound\": {}, \"local\": {}, \"unrealised\": {}}},",
        string(set),
        classes(&c.isolability.selected),
        c.isolability
            .candidates
            .as_ref()
            .map_or("null".to_string(), classes),
        classes(&c.isolability.possible),
        c.isolability
            .bound
            .as_ref()
            .map_or("null".to_string(), classes),
        c.isolability.capped,
        list(c.isolability.unrealised.iter().map(|u| {
            let names =
                |hs: &[Handle<Component>]| list(hs.iter().map(|&h| string(&c.components[h].name)));
            format!(
                "{{\"without\": {}, \"unseen\": {}, \"cancelled\": {}, \"complete\": {}, \"reasons\": {}}}",
                names(&u.without),
                names(&u.unseen),
                names(&u.cancelled),
                u.complete,
                list(u.reasons.iter().map(|r| string(r)))
            )
        }))
    );
}

fn diagnostics(out: &mut String, c: &Compiled) {
    let items: Vec<String> = c
        .diagnostics
        .iter()
        .map(|d| {
            let at = c.line_col(d.span);
            let severity = match d.severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            };
            format!(
                "\n    {{\"severity\": {}, \"code\": {}, \"message\": {}, \"line\": {}, \"column\": {}}}",
                string(severity),
                string(d.code.as_str()),
                string(&d.message),
                at.line,
                at.col
            )
        })
        .collect();
    if items.is_empty() {
        out.push_str("  \"diagnostics\": []\n");
    } else {
        let _ = writeln!(out, "  \"diagnostics\": [{}\n  ]", items.join(","));
    }
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
