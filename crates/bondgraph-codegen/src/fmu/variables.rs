//! The FMU's variables, with their value references: what the XML declares and the C
//! functions read and write.

use bondgraph_core::Compiled;

use crate::c::ident;

/// The sample step the FMU's `step` parameter starts at, in seconds.
pub(crate) const DEFAULT_STEP: f64 = 1e-3;
/// The estimator's window the `window` parameter starts at: `bgc residuals`' default.
const DEFAULT_WINDOW: u32 = 11;
/// The integration window the `integration_window` parameter starts at: the runtime's.
pub(crate) const DEFAULT_INTEGRATION: u32 = 250;
/// The size estimates' memory the `size.memory` parameter starts at, in samples.
const DEFAULT_MEMORY: u32 = 2000;

/// An FMI 3.0 variable type this FMU uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Type {
    /// `Float64`
    Float64,
    /// `Int32`
    Int32,
    /// `Boolean`
    Boolean,
    /// `String`
    String,
}

impl Type {
    /// The XML element's name.
    pub fn name(self) -> &'static str {
        match self {
            Type::Float64 => "Float64",
            Type::Int32 => "Int32",
            Type::Boolean => "Boolean",
            Type::String => "String",
        }
    }
}

/// A variable's causality.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    /// Time.
    Independent,
    /// A fixed parameter, set before initialisation.
    Parameter,
    /// A raw signal, set before each step.
    Input,
    /// A result, read after each step.
    Output,
}

impl Causality {
    /// The XML attribute's value.
    pub fn name(self) -> &'static str {
        match self {
            Causality::Independent => "independent",
            Causality::Parameter => "parameter",
            Causality::Input => "input",
            Causality::Output => "output",
        }
    }
}

/// What a variable is in the FMU's C instance.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Role {
    /// The time.
    Time,
    /// A raw signal, by its place in the generator's `raw`.
    Raw(usize),
    /// A model parameter, by its C field.
    Parameter(String),
    /// The record's sample step.
    Step,
    /// The estimator's window.
    Window,
    /// The Savitzky–Golay polynomial's degree.
    Degree,
    /// The integration window of residuals realised by integration (0: from the start).
    Integration,
    /// The debounce of the alarms.
    Debounce,
    /// Whether thresholds are adaptive.
    Adaptive,
    /// A residual's fixed threshold, by residual.
    Level(usize),
    /// The instant of the outputs.
    At,
    /// Whether the outputs hold an estimate.
    Ready,
    /// A residual.
    Residual(usize),
    /// A residual's threshold.
    Threshold(usize),
    /// A residual's alarm.
    Alarm(usize),
    /// The candidates' names.
    Candidates,
    /// The size estimates' memory.
    SizeMemory,
    /// A residual's noise level, by residual.
    SizeNoise(usize),
    /// Whether a parameter is sized, by its place among those sized.
    SizeOn(usize),
    /// A sized parameter's estimated value.
    SizeValue(usize),
    /// The half-width of its interval.
    SizeHalfWidth(usize),
    /// Its misfit.
    SizeMisfit(usize),
}

impl Role {
    /// The C lvalue the instance `m` holds it in.
    pub fn place(&self) -> String {
        match self {
            Role::Time => "m->time".into(),
            Role::Raw(k) => format!("m->raw[{k}]"),
            Role::Parameter(field) => format!("m->params.{field}"),
            Role::Step => "m->step".into(),
            Role::Window => "m->window".into(),
            Role::Degree => "m->degree".into(),
            Role::Integration => "m->integration".into(),
            Role::Debounce => "m->debounce".into(),
            Role::Adaptive => "m->adaptive".into(),
            Role::Level(k) => format!("m->levels[{k}]"),
            Role::At => "m->out.at".into(),
            Role::Ready => "m->ready".into(),
            Role::Residual(k) => format!("m->out.residuals[{k}]"),
            Role::Threshold(k) => format!("m->out.thresholds[{k}]"),
            Role::Alarm(k) => format!("m->out.alarms[{k}]"),
            Role::Candidates => "m->candidates".into(),
            Role::SizeMemory => "m->size_memory".into(),
            Role::SizeNoise(k) => format!("m->noise[{k}]"),
            Role::SizeOn(k) => format!("m->size_on[{k}]"),
            Role::SizeValue(k) => format!("m->size_out[{k}].value"),
            Role::SizeHalfWidth(k) => format!("m->size_out[{k}].half_width"),
            Role::SizeMisfit(k) => format!("m->size_out[{k}].misfit"),
        }
    }
}

/// One variable of the FMU.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// Its name (structured: `residual.ARR1`).
    pub name: String,
    /// Its value reference.
    pub reference: u32,
    /// Its type.
    pub ty: Type,
    /// Its causality.
    pub causality: Causality,
    /// Its start value as the XML writes it, where it has one.
    pub start: Option<String>,
    /// Its smallest value, where it has one.
    pub min: Option<String>,
    /// Its unit, where the model gives one.
    pub unit: Option<String>,
    /// What it is.
    pub description: String,
    /// Where the C instance holds it.
    pub role: Role,
}

impl Variable {
    /// Its variability: time and raw signals vary continuously, parameters are fixed, results
    /// change at each step.
    pub fn variability(&self) -> &'static str {
        match (self.causality, self.ty) {
            (Causality::Independent | Causality::Input, _) => "continuous",
            (Causality::Parameter, _) => "fixed",
            (Causality::Output, _) => "discrete",
        }
    }
}

/// A variable under construction.
fn var(name: String, ty: Type, causality: Causality, role: Role, description: String) -> Variable {
    Variable {
        name,
        reference: 0,
        ty,
        causality,
        start: None,
        min: None,
        unit: None,
        description,
        role,
    }
}

/// The FMU's variables, numbered from 0 in this order: time, the raw signals, the model's
/// parameters, the generator's settings and thresholds, then the outputs.
pub fn variables(c: &Compiled) -> Vec<Variable> {
    let program = c.program();
    let residuals: Vec<&str> = program.residuals.iter().map(|r| r.name.as_str()).collect();
    let mut vars = vec![var(
        "time".into(),
        Type::Float64,
        Causality::Independent,
        Role::Time,
        "Time".into(),
    )];
    for (k, raw) in program.raw.values().enumerate() {
        let what = match raw.signal {
            bondgraph_core::Signal::Input(_) => "input",
            bondgraph_core::Signal::Sensor(_) => "measured signal",
        };
        let mut v = var(
            raw.name.clone(),
            Type::Float64,
            Causality::Input,
            Role::Raw(k),
            format!("The {what} `{}`, sampled at the step's start", raw.name),
        );
        v.start = Some("0".into());
        vars.push(v);
    }
    for p in c.parameters.values() {
        let mut v = var(
            p.name.clone(),
            Type::Float64,
            Causality::Parameter,
            Role::Parameter(ident(&p.name)),
            p.description.clone().unwrap_or_default(),
        );
        v.start = Some(format!("{:?}", p.value));
        v.unit = p.unit.clone();
        vars.push(v);
    }
    vars.extend(settings(program.top_order()));
    for (k, name) in residuals.iter().enumerate() {
        let mut v = var(
            format!("decision.level.{name}"),
            Type::Float64,
            Causality::Parameter,
            Role::Level(k),
            format!("A fixed threshold on |{name}| (negative: none, and no alarm); with adaptive thresholds, the margin for noise over its bound"),
        );
        v.start = Some("-1".into());
        vars.push(v);
    }
    let sizable = sizable(c);
    vars.extend(size_settings(&residuals, &sizable));
    vars.extend(outputs(&residuals));
    vars.extend(size_outputs(&sizable));
    for (k, v) in vars.iter_mut().enumerate() {
        v.reference = k as u32;
    }
    vars
}

/// The parameters whose size the FMU estimates (those the residuals read): each one's place
/// among the model's parameters, and the parameter.
pub(crate) fn sizable(c: &Compiled) -> Vec<(usize, &bondgraph_core::Parameter)> {
    let read = c.program().parameters_read();
    (c.parameters.iter().enumerate())
        .filter(|(_, (h, _))| read.contains(h))
        .map(|(k, (_, p))| (k, p))
        .collect()
}

/// The size estimates' settings: their memory, each residual's noise and which parameters.
fn size_settings(
    residuals: &[&str],
    sizable: &[(usize, &bondgraph_core::Parameter)],
) -> Vec<Variable> {
    if sizable.is_empty() {
        return Vec::new();
    }
    let mut memory = var(
        "size.memory".into(),
        Type::Int32,
        Causality::Parameter,
        Role::SizeMemory,
        "Samples of typical information the size estimates forget over (their time constant): they follow a drift with that lag".into(),
    );
    memory.start = Some(DEFAULT_MEMORY.to_string());
    memory.min = Some("2".into());
    let mut vars = vec![memory];
    for (k, name) in residuals.iter().enumerate() {
        let mut v = var(
            format!("size.noise.{name}"),
            Type::Float64,
            Causality::Parameter,
            Role::SizeNoise(k),
            format!("The healthy RMS of {name}, its weight in the size estimates (negative: its decision level over 3; with neither, no size is estimated)"),
        );
        v.start = Some("-1".into());
        vars.push(v);
    }
    for (k, (_, p)) in sizable.iter().enumerate() {
        let mut v = var(
            format!("size.{}.on", p.name),
            Type::Boolean,
            Causality::Parameter,
            Role::SizeOn(k),
            format!(
                "Whether {}'s value is estimated (two more copies of the generator run)",
                p.name
            ),
        );
        v.start = Some("true".into());
        vars.push(v);
    }
    vars
}

/// Each sized parameter's estimate, interval and misfit.
fn size_outputs(sizable: &[(usize, &bondgraph_core::Parameter)]) -> Vec<Variable> {
    let mut vars = Vec::new();
    for (k, (_, p)) in sizable.iter().enumerate() {
        let name = &p.name;
        let mut value = var(
            format!("size.{name}.value"),
            Type::Float64,
            Causality::Output,
            Role::SizeValue(k),
            format!("{name}'s value as the residuals tell it, a fault's size (the model's until they have; not a number where it is not estimated)"),
        );
        value.unit = p.unit.clone();
        let mut half_width = var(
            format!("size.{name}.half_width"),
            Type::Float64,
            Causality::Output,
            Role::SizeHalfWidth(k),
            format!("The half-width of the 95 % interval of {name}'s value (infinite until the residuals have told it)"),
        );
        half_width.unit = p.unit.clone();
        let misfit = var(
            format!("size.{name}.misfit"),
            Type::Float64,
            Causality::Output,
            Role::SizeMisfit(k),
            format!("What a change of {name} alone leaves of the residuals, RMS in units of their noise: about 1 where it explains them all (the parameter that moved has the lowest)"),
        );
        vars.extend([value, half_width, misfit]);
    }
    vars
}

/// The generator's settings, as parameters.
fn settings(order: u32) -> Vec<Variable> {
    let int = |name: &str, role: Role, start: u32, min: u32, description: &str| {
        let mut v = var(
            name.into(),
            Type::Int32,
            Causality::Parameter,
            role,
            description.into(),
        );
        v.start = Some(start.to_string());
        v.min = Some(min.to_string());
        v
    };
    let mut step = var(
        "record.step".into(),
        Type::Float64,
        Causality::Parameter,
        Role::Step,
        "The record's sample step: every communication step must be it".into(),
    );
    step.start = Some(format!("{DEFAULT_STEP:?}"));
    step.unit = Some("s".into());
    let mut adaptive = var(
        "decision.adaptive".into(),
        Type::Boolean,
        Causality::Parameter,
        Role::Adaptive,
        "Adaptive thresholds: each level plus the residual's bound from the parameters' uncertainty (a residual with a bound and a negative level gets 0)".into(),
    );
    adaptive.start = Some("false".into());
    vec![
        step,
        int(
            "estimator.window",
            Role::Window,
            DEFAULT_WINDOW,
            3,
            "Samples in the Savitzky-Golay window (odd): the outputs lag the inputs by (window - 1)/2 samples",
        ),
        int(
            "estimator.degree",
            Role::Degree,
            order.max(3),
            order,
            "The Savitzky-Golay polynomial's degree",
        ),
        int(
            "integration.window",
            Role::Integration,
            DEFAULT_INTEGRATION,
            0,
            "Samples a residual realised by integration integrates over (0: from the first estimate)",
        ),
        int(
            "decision.debounce",
            Role::Debounce,
            1,
            1,
            "Consecutive samples above (below) a threshold that raise (clear) its alarm",
        ),
        adaptive,
    ]
}

/// The outputs: the estimate's instant, whether there is one, and per residual its value,
/// threshold and alarm; then the candidates.
fn outputs(residuals: &[&str]) -> Vec<Variable> {
    let out = |name: String, ty: Type, role: Role, description: String| {
        var(name, ty, Causality::Output, role, description)
    };
    let mut at = out(
        "estimate.at".into(),
        Type::Float64,
        Role::At,
        "The instant the outputs refer to: the step's start less the estimator's delay".into(),
    );
    at.unit = Some("s".into());
    let mut vars = vec![
        at,
        out(
            "estimate.ready".into(),
            Type::Boolean,
            Role::Ready,
            "Whether the estimator's window is full and the outputs hold an estimate".into(),
        ),
    ];
    for (k, name) in residuals.iter().enumerate() {
        vars.push(out(
            format!("residual.{name}"),
            Type::Float64,
            Role::Residual(k),
            format!("The residual of {name} (not a number until ready)"),
        ));
    }
    for (k, name) in residuals.iter().enumerate() {
        vars.push(out(
            format!("threshold.{name}"),
            Type::Float64,
            Role::Threshold(k),
            format!("The threshold on |{name}| (not a number where it has none)"),
        ));
    }
    for (k, name) in residuals.iter().enumerate() {
        vars.push(out(
            format!("alarm.{name}"),
            Type::Boolean,
            Role::Alarm(k),
            format!("Whether {name} is in alarm"),
        ));
    }
    vars.push(out(
        "candidates".into(),
        Type::String,
        Role::Candidates,
        "The components whose fault explains the alarms (the fault signature matrix's), space separated".into(),
    ));
    vars
}
