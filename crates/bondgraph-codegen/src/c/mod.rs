//! Residual code in C99: the same residual program the Rust backend prints, printed for a
//! bench PC, a real-time target or a Simulink S-function, with nothing beyond libm.
//!
//! [`emit`] writes a header (the types, the model's tables and the functions' prototypes)
//! and a source (the functions and, as `static` functions, the few pieces of the runtime
//! the generator needs: Savitzky–Golay weights, trapezoids, references, the root finder,
//! the copy's Runge–Kutta steps, thresholds), and the fault-size estimator over two copies
//! of the generator (`size.rs`). Every piece computes what the Rust runtime
//! computes, in the same order of operations, so that both give the same residuals to
//! rounding. Storage is fixed (no `malloc`): the longest window is a macro a firmware can
//! lower (`BGC_MAX_WINDOW`…).

mod context;
mod generator;
mod lower;
mod names;
mod size;

use std::cell::Cell;
use std::fmt::Write as _;

use bondgraph_core::program::Evaluation;
use bondgraph_core::{Compiled, ResidualForm};

use crate::rust::Unwritable;
use crate::signals::fields;
pub(crate) use context::{comment, string};
use context::{dim, Context, Names};
use lower::{number, Place};
pub(crate) use names::ident;
use names::prefix;

/// The runtime's types, shared by the headers of several models.
const TYPES: &str = include_str!("runtime/types.h");
/// What every generator runs.
const CORE: &str = include_str!("runtime/core.c");
/// Running trapezoidal integrals, where the program integrates a signal or an expression.
const TRAPEZOID: &str = include_str!("runtime/trapezoid.c");
/// References, where a residual is realised by integration.
const REFERENCE: &str = include_str!("runtime/reference.c");
/// `sign()`, where the program reads it.
const SIGN: &str = include_str!("runtime/sign.c");
/// The FSM's decision.
const FSM: &str = include_str!("runtime/fsm.c");
/// Newton's method and bisection, where the program solves a law for its root.
const ROOTS: &str = include_str!("runtime/roots.c");
/// The copy of the model, where a simulated residual runs one.
const REPLAY: &str = include_str!("runtime/replay.c");
/// The change estimator behind a fault's size.
const SIZE: &str = include_str!("runtime/size.c");

/// A model's C code: a header and the source that includes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CCode {
    /// The header's file name, as the source includes it (`backlash_bench.h`).
    pub header_name: String,
    /// The header: types, tables and prototypes.
    pub header: String,
    /// The source: the functions, with the runtime pieces they need.
    pub source: String,
}

impl CCode {
    /// The header and the source as one file that compiles alone (what `bgc --emit c` writes
    /// to standard output).
    pub fn single_file(&self) -> String {
        let include = format!("#include \"{}\"\n", self.header_name);
        format!("{}\n{}", self.header, self.source.replacen(&include, "", 1))
    }
}

/// The prefix of every name the model's C code declares, and its file names' stem: the
/// model's name as a C identifier (`backlash_bench`).
pub fn identifier(c: &Compiled) -> String {
    prefix(&c.name)
}

/// The model's C code, its header named `header_name` (`model.h`).
pub fn emit(c: &Compiled, header_name: &str) -> Result<CCode, Unwritable> {
    let refused = Cell::new(None);
    let reads_sign = Cell::new(false);
    let program = c.program();
    let readings = c.readings();
    let fields = fields(c, &program, &readings);
    let names = Names::new(c);
    let cx = Context {
        c,
        program: &program,
        fields: &fields,
        names: &names,
        refused: &refused,
        reads_sign: &reads_sign,
    };
    let header = header(&cx, header_name);
    let body = body(&cx);
    if let Some(why) = refused.get() {
        return Err(why);
    }
    let source = source(&cx, header_name, &body);
    Ok(CCode {
        header_name: header_name.to_string(),
        header,
        source,
    })
}

/// The header: counts, the runtime's types, `params`, `signals`, the generator, the tables
/// and the prototypes.
fn header(cx: &Context<'_>, header_name: &str) -> String {
    let (c, n) = (cx.c, cx.names);
    let guard = format!(
        "{}_H",
        prefix(header_name.trim_end_matches(".h")).to_ascii_uppercase()
    );
    let mut h = String::new();
    let _ = writeln!(
        h,
        "/* Residual code for the model `{}` ({}), written by bgc.\n   C99 and libm only: \
         compile the source with this header and link with -lm. */",
        comment(&c.name),
        comment(&c.file_name)
    );
    let _ = writeln!(h, "#ifndef {guard}\n#define {guard}\n");
    h += "#ifdef __cplusplus\nextern \"C\" {\n#endif\n\n";
    h += TYPES;
    h += "\n";
    let counts = [
        ("PARAMETERS", c.parameters.len(), "The model's parameters."),
        (
            "SIGNALS",
            cx.fields.len(),
            "The fields of the signals the residuals read.",
        ),
        ("RESIDUALS", cx.residuals(), "The residuals: one per ARR."),
        ("RAW", cx.program.raw.len(), "The raw signals push() takes."),
        (
            "CHANNELS",
            cx.program.channels.len(),
            "The signals the estimator bank takes.",
        ),
        (
            "COMPONENTS",
            c.components.len(),
            "The rows of the fault signature matrix.",
        ),
        (
            "ORDER",
            cx.program.top_order() as usize,
            "The highest derivative the ARRs read.",
        ),
    ];
    for (name, value, doc) in counts {
        let _ = writeln!(h, "/* {doc} */\n#define {} {value}", n.m(name));
    }
    h += "\n";
    h += &params_type(cx);
    h += &signals_type(cx);
    h += &generator::types(cx);
    h += &size::types(cx);
    h += &tables_declared(cx);
    h += &generator::prototypes(cx);
    h += &size::prototypes(cx);
    h += "\n#ifdef __cplusplus\n}\n#endif\n\n#endif\n";
    h
}

fn params_type(cx: &Context<'_>) -> String {
    let mut h = String::from(
        "/* The model's parameters; `_default_params` holds the values it declares. */\ntypedef struct {\n",
    );
    for p in cx.c.parameters.values() {
        let mut doc = String::new();
        if let Some(u) = &p.unit {
            let _ = write!(doc, "[{u}] ");
        }
        if let Some(d) = &p.description {
            let _ = write!(doc, "{d} ");
        }
        let _ = writeln!(
            h,
            "    double {}; /* {}(model value {}) */",
            ident(&p.name),
            comment(&doc),
            p.value
        );
    }
    if cx.c.parameters.is_empty() {
        h += "    double none; /* the model has no parameter */\n";
    }
    let _ = writeln!(h, "}} {};\n", cx.names.f("params"));
    h
}

fn signals_type(cx: &Context<'_>) -> String {
    let mut h = String::from(
        "/* What the residuals read: the inputs and measured signals, their time derivatives\n   \
         (NAME_d1, NAME_d2...) and integrals from the start of the record (NAME_int). */\ntypedef struct {\n",
    );
    for f in cx.fields {
        let _ = writeln!(
            h,
            "    double {}; /* {} */",
            ident(&f.name),
            comment(&f.doc)
        );
    }
    if cx.fields.is_empty() {
        h += "    double none; /* the residuals read no signal */\n";
    }
    let _ = writeln!(h, "}} {};\n", cx.names.f("signals"));
    h
}

/// The `extern` declarations of the model's tables.
fn tables_declared(cx: &Context<'_>) -> String {
    let n = cx.names;
    let p = n.f("params");
    let lines = [
        format!("/* The values the model declares. */\nextern const {p} {};", n.f("default_params")),
        format!(
            "/* How far each parameter's true value may be from the model's (`+- 5%`), as a\n   half-width in its unit; 0 for those it states exactly. */\nextern const {p} {};",
            n.f("uncertainty")
        ),
        format!("/* The parameters' names, in the order of the fields. */\nextern const char *const {}[{}];", n.f("parameter_names"), dim(cx.c.parameters.len())),
        format!(
            "/* Whether the residuals read each parameter: those whose size _size_init estimates. */\nextern const int {}[{}];",
            n.f("sizable"),
            dim(cx.c.parameters.len())
        ),
        format!("/* The signals' names, in the order of the fields. */\nextern const char *const {}[{}];", n.f("signal_names"), dim(cx.fields.len())),
        format!("/* The ARRs' names, in the order of the residuals. */\nextern const char *const {}[{}];", n.f("residual_names"), dim(cx.residuals())),
        format!(
            "/* Whether each residual is realised by integration: the ARR r = A + dF/dt is evaluated\n   as the running value F + int(A), whose change over the integration window is the\n   residual. */\nextern const int {}[{}];",
            n.f("integrated"),
            dim(cx.residuals())
        ),
        format!(
            "/* Whether each residual is simulated: it compares a measured signal with a copy of the\n   model run on the recorded inputs from rest. */\nextern const int {}[{}];",
            n.f("simulated"),
            dim(cx.residuals())
        ),
        format!("/* Whether each residual has a bound from the parameters' uncertainty. */\nextern const int {}[{}];", n.f("has_bound"), dim(cx.residuals())),
        format!("/* The raw signals push() takes, in order. */\nextern const char *const {}[{}];", n.f("raw_names"), dim(cx.program.raw.len())),
        format!("/* The highest derivative of each raw signal the ARRs read. */\nextern const int {}[{}];", n.f("raw_orders"), dim(cx.program.raw.len())),
        format!("/* The FSM's rows: each component's name and kind. */\nextern const char *const {}[{}];\nextern const char *const {}[{}];", n.f("component_names"), dim(cx.c.components.len()), n.f("component_kinds"), dim(cx.c.components.len())),
        format!(
            "/* Each component's signature, sparse: the residuals a fault of component c moves\n   are marks[start[c]] to marks[start[c + 1] - 1]. */\nextern const int {}[{}];\nextern const int {}[{}];",
            n.f("signature_start"),
            cx.c.components.len() + 1,
            n.f("signature_marks"),
            dim(marks(cx.c).len())
        ),
        format!("/* Whether each component's fault is detectable, and isolable. */\nextern const int {}[{}];\nextern const int {}[{}];", n.f("detectable"), dim(cx.c.components.len()), n.f("isolable"), dim(cx.c.components.len())),
        format!(
            "\n/* Every ARR's residual; each is zero (up to the estimation of the signals) while the\n   machine is healthy. For one realised by integration, the running value F + int(A). */\nvoid {}(const {p} *p, const {} *s, double r[{}]);",
            n.f("residuals"),
            n.f("signals"),
            dim(cx.residuals())
        ),
        format!(
            "/* Each residual's bound from the parameters' uncertainty u at the signals s:\n   sum |dr/dtheta| u.theta; 0 for an ARR without one. */\nvoid {}(const {p} *p, const {p} *u, const {} *s, double b[{}]);",
            n.f("bounds"),
            n.f("signals"),
            dim(cx.residuals())
        ),
        format!(
            "/* The components whose fault explains the residuals in alarm (one flag per residual):\n   those whose signature equals them, or else those whose signature holds every alarm.\n   Their indices go to out; returns how many. */\nint {}(const int alarms[{}], int out[{}]);",
            n.f("candidates"),
            dim(cx.residuals()),
            dim(cx.c.components.len())
        ),
        format!(
            "/* The components whose signature holds every alarm (no exoneration). */\nint {}(const int alarms[{}], int out[{}]);\n",
            n.f("suspects"),
            dim(cx.residuals()),
            dim(cx.c.components.len())
        ),
    ];
    lines.join("\n") + "\n"
}

/// Every component's marks, one after the other.
fn marks(c: &Compiled) -> Vec<usize> {
    c.components
        .values()
        .flat_map(|comp| comp.marks.iter().copied())
        .collect()
}

/// The functions that print program code (the refusals are known once they are printed).
struct Body {
    residuals: String,
    bounds: String,
    copy: String,
    push: String,
}

fn body(cx: &Context<'_>) -> Body {
    Body {
        residuals: residuals_fn(cx),
        bounds: bounds_fn(cx),
        copy: generator::copy_rates(cx),
        push: generator::functions(cx),
    }
}

/// The source: includes, the runtime pieces it needs, the tables and the functions.
fn source(cx: &Context<'_>, header_name: &str, body: &Body) -> String {
    let mut s = format!(
        "/* Residual code for the model `{}` ({}), written by bgc. */\n#include \"{header_name}\"\n\n#include <float.h>\n#include <math.h>\n#include <stddef.h>\n\n",
        comment(&cx.c.name),
        comment(&cx.c.file_name)
    );
    s += "/* The runtime: what the generator is built of, as the Rust runtime computes it. */\n\n";
    s += CORE;
    s += "\n";
    s += FSM;
    // Only the pieces the program runs: C warns of an unused static function.
    let counts = generator::counts(cx);
    let pieces = [
        (counts.integrals + counts.others > 0, TRAPEZOID),
        (counts.references > 0, REFERENCE),
        (cx.reads_sign.get(), SIGN),
        (counts.roots > 0, ROOTS),
    ];
    for (_, piece) in pieces.iter().filter(|(needed, _)| *needed) {
        s += "\n";
        s += piece;
    }
    if cx.program.copy.is_some() {
        s += "\n";
        s += REPLAY;
    }
    s += "\n";
    s += SIZE;
    s += "\n/* The model. */\n\n";
    s += &tables(cx);
    s += &body.residuals;
    s += &body.bounds;
    s += &fsm_fns(cx);
    s += &body.copy;
    s += &body.push;
    s += &size::functions(cx);
    s
}

/// A `const` array's definition from its items.
fn array(ty: &str, name: &str, items: &[String]) -> String {
    let len = dim(items.len());
    let items = if items.is_empty() {
        // C has no empty arrays: the one element stands for none.
        "0".to_string()
    } else {
        items.join(", ")
    };
    format!("const {ty} {name}[{len}] = {{{items}}};\n")
}

fn tables(cx: &Context<'_>) -> String {
    let (c, n, program) = (cx.c, cx.names, cx.program);
    let mut s = String::new();
    let values = |f: &dyn Fn(&bondgraph_core::Parameter) -> f64| -> String {
        if c.parameters.is_empty() {
            return "0.0".to_string();
        }
        (c.parameters.values())
            .map(|p| format!(".{} = {}", ident(&p.name), number(f(p), cx.refused).0))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        s,
        "const {} {} = {{{}}};",
        n.f("params"),
        n.f("default_params"),
        values(&|p| p.value)
    );
    let _ = writeln!(
        s,
        "const {} {} = {{{}}};",
        n.f("params"),
        n.f("uncertainty"),
        values(&|p| p.uncertainty.unwrap_or(0.0))
    );
    let strings = |names: Vec<&str>| -> Vec<String> { names.into_iter().map(string).collect() };
    let flags = |flags: Vec<bool>| -> Vec<String> {
        flags.into_iter().map(|f| u8::from(f).to_string()).collect()
    };
    let residuals = &program.residuals;
    s += &array(
        "char *const",
        &n.f("parameter_names"),
        &strings(c.parameters.values().map(|p| p.name.as_str()).collect()),
    );
    let read = program.parameters_read();
    s += &array(
        "int",
        &n.f("sizable"),
        &flags(
            (c.parameters.iter())
                .map(|(h, _)| read.contains(&h))
                .collect(),
        ),
    );
    s += &array(
        "char *const",
        &n.f("signal_names"),
        &strings(cx.fields.iter().map(|f| f.name.as_str()).collect()),
    );
    s += &array(
        "char *const",
        &n.f("residual_names"),
        &strings(residuals.iter().map(|r| r.name.as_str()).collect()),
    );
    s += &array(
        "int",
        &n.f("integrated"),
        &flags(
            (residuals.iter())
                .map(|r| r.evaluation == Evaluation::Integrated)
                .collect(),
        ),
    );
    s += &array(
        "int",
        &n.f("simulated"),
        &flags(
            (c.arrs.iter())
                .map(|a| a.form == ResidualForm::Simulated)
                .collect(),
        ),
    );
    s += &array(
        "int",
        &n.f("has_bound"),
        &flags(
            (0..residuals.len())
                .map(|k| program.sensitivities.iter().any(|s| s.residual == k))
                .collect(),
        ),
    );
    s += &array(
        "char *const",
        &n.f("raw_names"),
        &strings(program.raw.values().map(|r| r.name.as_str()).collect()),
    );
    s += &array(
        "int",
        &n.f("raw_orders"),
        &(program.raw.values())
            .map(|r| r.order.to_string())
            .collect::<Vec<_>>(),
    );
    let comps: Vec<_> = c.components.values().collect();
    s += &array(
        "char *const",
        &n.f("component_names"),
        &strings(comps.iter().map(|k| k.name.as_str()).collect()),
    );
    s += &array(
        "char *const",
        &n.f("component_kinds"),
        &strings(comps.iter().map(|k| k.kind.name()).collect()),
    );
    let mut start = vec!["0".to_string()];
    let mut total = 0;
    for comp in &comps {
        total += comp.marks.len();
        start.push(total.to_string());
    }
    s += &array("int", &n.f("signature_start"), &start);
    s += &array(
        "int",
        &n.f("signature_marks"),
        &marks(c).iter().map(usize::to_string).collect::<Vec<_>>(),
    );
    s += &array(
        "int",
        &n.f("detectable"),
        &flags(comps.iter().map(|k| k.detectable).collect()),
    );
    s += &array(
        "int",
        &n.f("isolable"),
        &flags(comps.iter().map(|k| k.isolable).collect()),
    );
    s + "\n"
}

fn residuals_fn(cx: &Context<'_>) -> String {
    let n = cx.names;
    let mut lower = cx.lowering(Place::Residuals);
    let roots: Vec<_> = cx.program.residuals.iter().map(|r| r.code).collect();
    let lets = lower.bind_shared(&roots, &cx.program.named, "t");
    let mut s = format!(
        "void {}(const {} *p, const {} *s, double r[{}])\n{{\n",
        n.f("residuals"),
        n.f("params"),
        n.f("signals"),
        dim(roots.len())
    );
    s += "    (void)p;\n    (void)s;\n";
    for line in lets {
        s += &line;
        s += "\n";
    }
    for (k, &root) in roots.iter().enumerate() {
        let _ = writeln!(s, "    r[{k}] = {};", lower.code(root));
    }
    if roots.is_empty() {
        s += "    (void)r;\n";
    }
    s + "}\n\n"
}

fn bounds_fn(cx: &Context<'_>) -> String {
    let (n, program) = (cx.names, cx.program);
    let mut lower = cx.lowering(Place::Residuals);
    let roots: Vec<_> = program.sensitivities.iter().map(|s| s.code).collect();
    let lets = lower.bind_shared(&roots, &[], "b");
    let mut s = format!(
        "void {}(const {p} *p, const {p} *u, const {} *s, double b[{}])\n{{\n",
        n.f("bounds"),
        n.f("signals"),
        dim(program.residuals.len()),
        p = n.f("params"),
    );
    s += "    (void)p;\n    (void)u;\n    (void)s;\n";
    for line in lets {
        s += &line;
        s += "\n";
    }
    for k in 0..program.residuals.len() {
        let terms: Vec<String> = (program.sensitivities.iter())
            .filter(|s| s.residual == k)
            .map(|s| {
                format!(
                    "fabs({}) * u->{}",
                    lower.code(s.code),
                    ident(&cx.c.parameters[s.parameter].name)
                )
            })
            .collect();
        let sum = if terms.is_empty() {
            "0.0".to_string()
        } else {
            terms.join(" + ")
        };
        let _ = writeln!(s, "    b[{k}] = {sum};");
    }
    if program.residuals.is_empty() {
        s += "    (void)b;\n";
    }
    s + "}\n\n"
}

fn fsm_fns(cx: &Context<'_>) -> String {
    let n = cx.names;
    let (r, k) = (dim(cx.residuals()), dim(cx.c.components.len()));
    let mut s = String::new();
    for (name, exactly) in [("candidates", 1), ("suspects", 0)] {
        let _ = writeln!(
            s,
            "int {}(const int alarms[{r}], int out[{k}])\n{{\n    return bgc_fsm_match({}, {}, {}, alarms, {}, {exactly}, out);\n}}\n",
            n.f(name),
            n.f("signature_start"),
            n.f("signature_marks"),
            n.m("COMPONENTS"),
            n.m("RESIDUALS"),
        );
    }
    s
}
