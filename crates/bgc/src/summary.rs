//! What `bgc check` prints about a valid model.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use bondgraph_core::graph::{BondGraph, NodeKind};

/// The summary of a model: counts by kind, then parameters and inputs.
pub fn check(model: &BondGraph) -> String {
    let counts = model.counts();
    let mut by_kind: BTreeMap<&str, usize> = BTreeMap::new();
    for id in model.nodes() {
        if let NodeKind::Element(kind, _) = model.node(id).kind {
            *by_kind.entry(kind.name()).or_default() += 1;
        }
    }
    let kinds: Vec<String> = by_kind.iter().map(|(k, n)| format!("{k} {n}")).collect();
    let mut out = String::new();
    let _ = writeln!(out, "model {}: valid", model.name);
    let _ = writeln!(
        out,
        "  elements   {:>6}  ({})",
        counts.elements,
        kinds.join(", ")
    );
    let _ = writeln!(out, "  bonds      {:>6}", counts.bonds);
    let _ = writeln!(out, "  junctions  {:>6}", counts.junctions);
    let _ = writeln!(out, "  detectors  {:>6}", counts.detectors);
    let _ = writeln!(out, "parameters ({})", model.params.len());
    let name_width = model.params.iter().map(|p| p.name.len()).max().unwrap_or(0);
    let values: Vec<String> = model.params.iter().map(|p| p.value.to_string()).collect();
    let value_width = values.iter().map(String::len).max().unwrap_or(0);
    let units: Vec<String> = model
        .params
        .iter()
        .map(|p| {
            p.unit
                .as_ref()
                .map(|u| format!("[{u}]"))
                .unwrap_or_default()
        })
        .collect();
    let unit_width = units.iter().map(String::len).max().unwrap_or(0);
    for ((p, value), unit) in model.params.iter().zip(&values).zip(&units) {
        let line = format!(
            "  {:<name_width$} = {value:<value_width$}  {unit:<unit_width$}  {}",
            p.name,
            p.description.as_deref().unwrap_or("")
        );
        let _ = writeln!(out, "{}", line.trim_end());
    }
    let inputs: Vec<&str> = model.inputs.iter().map(|i| i.name.as_str()).collect();
    let _ = writeln!(out, "inputs ({}) {}", inputs.len(), inputs.join(" "));
    out
}
