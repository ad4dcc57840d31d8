//! An FMI 3.0 co-simulation FMU of the residual generator: its `modelDescription.xml`, the C
//! functions of the FMI interface over the C backend's generator, and the build description
//! of its sources. One table of variables ([`variables`]) gives both the XML and the C, so
//! that a value reference means the same thing in both.
//!
//! Per `fmi3DoStep(t, h)`, the FMU takes the inputs set for `t` as the record's sample at `t`
//! (`h` must be the record's step, a parameter) and outputs the estimate at `at = t - delay`
//! once the estimator's window is full (`ready`): the residuals, their thresholds, alarms
//! and the FSM's candidates; and, from the first sample, the size of each parameter the
//! residuals read (the C code's size estimator, one per parameter switched on). Packaging
//! (compiling, zipping) is the CLI's.

mod variables;
mod wrapper;

use std::fmt::Write as _;

use bondgraph_core::Compiled;

use crate::c::{self, CCode};
use crate::rust::Unwritable;
pub use variables::{variables, Causality, Role, Type, Variable};

/// The files of an FMU but its binary.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FmuSources {
    /// The model identifier: the binary's and the sources' stem, a C identifier.
    pub identifier: String,
    /// `modelDescription.xml`
    pub model_description: String,
    /// `sources/buildDescription.xml`
    pub build_description: String,
    /// The residual generator in C (`sources/ID.c`, `sources/ID.h`).
    pub code: CCode,
    /// The FMI functions over it (`sources/ID_fmi3.c`).
    pub wrapper: String,
    /// The wrapper's file name.
    pub wrapper_name: String,
}

/// The FMU's sources and description for a model; `tool` names the generating tool
/// (`bgc 0.1.0`).
pub fn emit(c: &Compiled, tool: &str) -> Result<FmuSources, Unwritable> {
    let identifier = c::identifier(c);
    let code = c::emit(c, &format!("{identifier}.h"))?;
    let wrapper_name = format!("{identifier}_fmi3.c");
    let token = token(&[&code.header, &code.source]);
    let vars = variables(c);
    // The FMU's own names hold a dot, which no model name does; only `time` can be taken.
    if (vars.iter().skip(1)).any(|v| v.name == "time") {
        return Err(Unwritable(
            "a name `time` in the model, which an FMU's independent variable is called",
        ));
    }
    let wrapper = wrapper::emit(c, &identifier, &vars, &token);
    let model_description = model_description(c, &identifier, &vars, &token, tool);
    let build_description = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiBuildDescription fmiVersion=\"3.0\">\n  <BuildConfiguration modelIdentifier=\"{identifier}\">\n    <SourceFileSet language=\"C99\">\n      <SourceFile name=\"{identifier}.c\"/>\n      <SourceFile name=\"{wrapper_name}\"/>\n    </SourceFileSet>\n    <Library name=\"m\" external=\"true\" description=\"libm, for exp, log, sqrt...\"/>\n  </BuildConfiguration>\n</fmiBuildDescription>\n"
    );
    Ok(FmuSources {
        identifier,
        model_description,
        build_description,
        code,
        wrapper,
        wrapper_name,
    })
}

/// The instantiation token: a GUID from a 128-bit FNV-1a of the generator's code, so that the
/// same model gives the same token and a changed one another.
fn token(parts: &[&str]) -> String {
    let mut hash: u128 = 0x6c62_272e_07bb_0142_62b8_2175_6295_c58d;
    for part in parts {
        for &b in part.as_bytes() {
            hash ^= u128::from(b);
            hash = hash.wrapping_mul(0x0000_0000_0100_0000_0000_0000_0000_013b);
        }
    }
    let h = format!("{hash:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &h[..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..]
    )
}

/// `s` as XML attribute text.
pub(crate) fn xml(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' | '\r' | '\t' => out.push(' '),
            ch if ch.is_control() => {}
            ch => out.push(ch),
        }
    }
    out
}

fn model_description(
    c: &Compiled,
    identifier: &str,
    vars: &[Variable],
    token: &str,
    tool: &str,
) -> String {
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        x,
        "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"{}\" instantiationToken=\"{token}\" description=\"{}\" generationTool=\"{}\" variableNamingConvention=\"structured\">",
        xml(&c.name),
        xml(&format!(
            "The residual generator of the bond graph `{}` ({}): its ARRs evaluated on the measured signals and inputs, with thresholds, alarms and the fault signature matrix's candidates",
            c.name, c.file_name
        )),
        xml(tool)
    );
    let _ = writeln!(
        x,
        "  <CoSimulation modelIdentifier=\"{identifier}\" canHandleVariableCommunicationStepSize=\"false\" canGetAndSetFMUState=\"false\" canSerializeFMUState=\"false\" providesDirectionalDerivatives=\"false\" providesAdjointDerivatives=\"false\" hasEventMode=\"false\"/>"
    );
    let mut units: Vec<&str> = vars.iter().filter_map(|v| v.unit.as_deref()).collect();
    units.sort_unstable();
    units.dedup();
    if !units.is_empty() {
        x += "  <UnitDefinitions>\n";
        for u in units {
            let _ = writeln!(x, "    <Unit name=\"{}\"/>", xml(u));
        }
        x += "  </UnitDefinitions>\n";
    }
    x += "  <LogCategories>\n    <Category name=\"logStatusError\" description=\"A call the FMU refuses, and why\"/>\n  </LogCategories>\n";
    let _ = writeln!(
        x,
        "  <DefaultExperiment startTime=\"0\" stepSize=\"{}\"/>",
        variables::DEFAULT_STEP
    );
    x += "  <ModelVariables>\n";
    for v in vars {
        x += &variable_xml(v);
    }
    x += "  </ModelVariables>\n  <ModelStructure>\n";
    let outputs: Vec<&Variable> = (vars.iter())
        .filter(|v| v.causality == Causality::Output)
        .collect();
    for v in &outputs {
        let _ = writeln!(x, "    <Output valueReference=\"{}\"/>", v.reference);
    }
    for v in &outputs {
        let _ = writeln!(
            x,
            "    <InitialUnknown valueReference=\"{}\"/>",
            v.reference
        );
    }
    x += "  </ModelStructure>\n</fmiModelDescription>\n";
    x
}

fn variable_xml(v: &Variable) -> String {
    let mut attrs = format!(
        "name=\"{}\" valueReference=\"{}\" causality=\"{}\" variability=\"{}\"",
        xml(&v.name),
        v.reference,
        v.causality.name(),
        v.variability()
    );
    if !v.description.is_empty() {
        let _ = write!(attrs, " description=\"{}\"", xml(&v.description));
    }
    if let Some(unit) = &v.unit {
        let _ = write!(attrs, " unit=\"{}\"", xml(unit));
    }
    if let Some(min) = &v.min {
        let _ = write!(attrs, " min=\"{min}\"");
    }
    match (&v.start, v.ty) {
        (Some(start), Type::String) => format!(
            "    <String {attrs}>\n      <Start value=\"{}\"/>\n    </String>\n",
            xml(start)
        ),
        (Some(start), ty) => format!("    <{} {attrs} start=\"{start}\"/>\n", ty.name()),
        (None, ty) => format!("    <{} {attrs}/>\n", ty.name()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_guids_that_follow_the_code() {
        let a = token(&["int x;"]);
        assert_eq!(a.len(), 38, "{a}");
        assert!(a.starts_with('{') && a.ends_with('}'));
        assert_eq!(a, token(&["int x;"]));
        assert_ne!(a, token(&["int y;"]));
    }

    #[test]
    fn xml_text_is_escaped() {
        assert_eq!(xml("a<b & \"c\"\n"), "a&lt;b &amp; &quot;c&quot; ");
    }
}
