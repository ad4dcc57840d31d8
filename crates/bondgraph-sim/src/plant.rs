//! The plant a scenario drives: the product's state equations with the scenario's inputs,
//! closed loops and faults put in, as straight-line tapes over one state vector.
//!
//! Every input the scenario defines is an expression of time, `let` signals, the model's
//! parameters (nominal values) and measured signals with their derivatives, taken along the
//! state equations. An `int(..)` anywhere (a law's twist, a PI controller) becomes one more
//! state. An input that reads itself, through a measured signal or another input, is an
//! algebraic loop and is refused.

use std::collections::HashMap;

use bondgraph_core::diagnostic::{Code, Diagnostic, Diagnostics, Span};
use bondgraph_core::{
    AstExpr, BinOp, Compiled, Derivatives, ExprId, FastMap, Handle, Ident, LoopUnknown, Node,
    Parameter, Pool, State, Symbol, Tape,
};

use crate::scenario::{FaultMode, FaultTarget, Onset, Quantiser, Scenario};

/// A leaf of the simulated plant's expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum P {
    /// A model state.
    State(Handle<State>),
    /// A parameter of the plant as it is at the time (faults applied).
    Param(Handle<Parameter>),
    /// An input as commanded, while the inputs are being put in.
    Input(u32),
    /// Its n-th derivative (n ≥ 1), likewise.
    InputDer(u32, u32),
    /// The course of the scenario's k-th signal fault at the time: a gain or an offset.
    Fault(u32),
    Time,
    /// An unknown of the model's nonlinear algebraic loops, found numerically.
    Loop(Handle<LoopUnknown>),
}

type Id = ExprId<P>;

/// How a parameter of the plant changes over the run.
#[derive(Clone, Debug)]
pub(crate) struct Course {
    pub nominal: f64,
    /// Each fault on it: when, and the value it brings.
    pub changes: Vec<(Onset, f64)>,
}

impl Course {
    pub(crate) fn at(&self, t: f64) -> f64 {
        self.changes.iter().fold(self.nominal, |v, &(onset, to)| {
            v + (to - self.nominal) * onset.fraction(t)
        })
    }
}

/// A fault on a measured signal or an input.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SignalFault {
    pub mode: FaultMode,
    pub size: f64,
    pub onset: Onset,
}

impl SignalFault {
    /// Its gain (1 when absent) or offset (0 when absent) at `t`.
    pub(crate) fn at(&self, t: f64) -> f64 {
        let f = self.onset.fraction(t);
        match self.mode {
            FaultMode::Additive => self.size * f,
            FaultMode::Multiplicative => 1.0 + (self.size - 1.0) * f,
        }
    }
}

/// The plant, ready to integrate.
#[derive(Clone, Debug)]
pub(crate) struct Plant {
    /// The model states, then one per `int(..)`.
    pub state_names: Vec<String>,
    pub model_states: usize,
    /// Each state's derivative.
    pub derivative: Tape<P>,
    /// The recorded signals: the inputs as commanded, then the measured signals as reported.
    pub recorded: Tape<P>,
    pub recorded_names: Vec<String>,
    /// How many of the recorded signals are inputs (they come first).
    pub inputs: usize,
    /// The unknowns of nonlinear algebraic loops, by name.
    pub loop_names: Vec<String>,
    /// Their residuals: zero at the unknowns' values.
    pub loops: Tape<P>,
    /// Where each `int(..)` node's value sits in the state vector.
    pub integrals: FastMap<Id, usize>,
    pub params: Vec<Course>,
    pub faults: Vec<SignalFault>,
    pub initial: Vec<f64>,
    /// Standard deviation of the noise on each recorded signal.
    pub noise: Vec<f64>,
    /// How each recorded signal is quantised, where it is.
    pub quantisers: Vec<Option<Quantiser>>,
    /// Times where a fault's course has a kink.
    pub breaks: Vec<f64>,
}

/// The names a scenario can read, and what each is in the product.
struct Names<'c> {
    c: &'c Compiled,
    lets: HashMap<String, Id>,
}

enum Name {
    Parameter(usize),
    Input(usize),
    Sensor(usize),
    Let(Id),
    Time,
}

impl Names<'_> {
    fn find(&self, name: &str) -> Option<Name> {
        if name == "t" {
            return Some(Name::Time);
        }
        if let Some(&id) = self.lets.get(name) {
            return Some(Name::Let(id));
        }
        let c = self.c;
        position(c.parameters.iter().map(|(_, p)| p.name.as_str()), name)
            .map(Name::Parameter)
            .or_else(|| {
                position(c.inputs.iter().map(|(_, u)| u.name.as_str()), name).map(Name::Input)
            })
            .or_else(|| {
                position(c.sensors.iter().map(|(_, s)| s.name.as_str()), name).map(Name::Sensor)
            })
    }
}

/// Builds the plant of `c` under `scenario`, or the scenario's mistakes (spans in its text).
pub(crate) fn build(c: &Compiled, scenario: &Scenario) -> Result<Plant, Diagnostics> {
    let mut errors = Diagnostics::default();
    let Some(space) = c.state_space.as_ref() else {
        errors.push(Diagnostic::error(
            Code::Refused,
            Span::new(0, 0),
            format!(
                "`{}` has no state equations to simulate (see the model's errors)",
                c.name
            ),
        ));
        return Err(errors);
    };
    let mut b = Builder {
        c,
        pool: Pool::default(),
        rhs: Vec::new(),
        measured: Vec::new(),
        faults: Vec::new(),
        loops: Vec::new(),
        errors: Diagnostics::default(),
    };
    b.import(space, scenario);
    let noise = b.noise(scenario);
    let quantisers = b.quantisers(scenario);
    let (commands, written) = b.commands(scenario);
    let commands = b.close_loops(commands, &written);
    if b.errors.has_errors() {
        b.errors.sort();
        return Err(b.errors);
    }
    let mut plant = b.finish(scenario, &commands, noise)?;
    plant.quantisers = quantisers;
    Ok(plant)
}

struct Builder<'c> {
    c: &'c Compiled,
    pool: Pool<P>,
    /// The model states' derivatives, over states and input placeholders.
    rhs: Vec<Id>,
    /// The measured signals as reported (faults applied), over the same.
    measured: Vec<Id>,
    faults: Vec<SignalFault>,
    /// Each loop unknown's name and residual, over the same.
    loops: Vec<(String, Id)>,
    errors: Diagnostics,
}

impl Builder<'_> {
    /// The state equations and outputs with the scenario's faults on actuators and sensors.
    fn import(&mut self, space: &bondgraph_core::StateSpace, scenario: &Scenario) {
        let c = self.c;
        let mut received: Vec<Id> = (0..c.inputs.len() as u32)
            .map(|u| self.pool.leaf(P::Input(u)))
            .collect();
        let mut measured_faults: Vec<Vec<(FaultMode, u32)>> = vec![Vec::new(); c.sensors.len()];
        for f in &scenario.faults {
            let (name, mode, is_sensor) = match &f.target {
                FaultTarget::Sensor(name, mode) => (name, *mode, true),
                FaultTarget::Actuator(name, mode) => (name, *mode, false),
                FaultTarget::Parameter(_) => continue,
            };
            let Some(size) = self.constant(&f.size) else {
                continue;
            };
            let k = self.faults.len() as u32;
            self.faults.push(SignalFault {
                mode,
                size,
                onset: f.onset,
            });
            let found = if is_sensor {
                position(c.sensors.iter().map(|(_, s)| s.name.as_str()), &name.name)
                    .map(|s| measured_faults[s].push((mode, k)))
            } else {
                position(c.inputs.iter().map(|(_, u)| u.name.as_str()), &name.name).map(|u| {
                    let leaf = self.pool.leaf(P::Fault(k));
                    received[u] = apply(&mut self.pool, received[u], mode, leaf);
                })
            };
            if found.is_none() {
                let what = if is_sensor {
                    "measured signal"
                } else {
                    "input"
                };
                self.undefined(name, what);
            }
        }
        let faulted: Vec<&str> = scenario
            .faults
            .iter()
            .filter_map(|f| match &f.target {
                FaultTarget::Parameter(name) => Some(name.name.as_str()),
                _ => None,
            })
            .collect();
        let import = |pool: &mut Pool<P>, e| {
            let e = pool.import_from(&c.exprs, e, |p: &mut Pool<P>, s| match s {
                // A parameter no fault changes is a number, so that what it takes part in
                // is computed once, here, not at every step.
                Symbol::Parameter(k) if !faulted.contains(&c.parameters[k].name.as_str()) => {
                    p.num(c.parameters[k].value)
                }
                Symbol::Parameter(k) => p.leaf(P::Param(k)),
                Symbol::Input(u, 0) => received[u.index()],
                Symbol::Input(u, n) => p.leaf(P::InputDer(u.index() as u32, n)),
                Symbol::State(k) => p.leaf(P::State(k)),
                // State equations and outputs read neither measured nor auxiliary signals.
                Symbol::Sensor(..) | Symbol::Auxiliary(..) | Symbol::Root(..) => p.num(f64::NAN),
                Symbol::Time => p.leaf(P::Time),
                Symbol::Loop(k) => p.leaf(P::Loop(k)),
            });
            inside_integrals(pool, e)
        };
        self.loops = space
            .loops
            .iter()
            .map(|l| (l.name.clone(), import(&mut self.pool, l.residual)))
            .collect();
        let mut rhs = vec![self.pool.num(0.0); c.model_states()];
        for (k, e) in &space.equations {
            rhs[k.index()] = import(&mut self.pool, *e);
        }
        let mut measured = vec![self.pool.num(0.0); c.sensors.len()];
        for (s, e) in &space.outputs {
            let mut y = import(&mut self.pool, *e);
            for &(mode, k) in &measured_faults[s.index()] {
                let leaf = self.pool.leaf(P::Fault(k));
                y = apply(&mut self.pool, y, mode, leaf);
            }
            measured[s.index()] = y;
        }
        self.rhs = rhs;
        self.measured = measured;
    }

    /// Each input's command as the scenario writes it, over placeholders for the inputs.
    fn commands(&mut self, scenario: &Scenario) -> (Vec<Option<(Id, Span)>>, Vec<bool>) {
        let mut names = Names {
            c: self.c,
            lets: HashMap::new(),
        };
        for (name, e) in &scenario.lets {
            if let Some(id) = self.resolve(e, &names) {
                names.lets.insert(name.name.clone(), id);
            }
        }
        let mut commands = vec![None; self.c.inputs.len()];
        let mut written = vec![false; self.c.inputs.len()];
        for (name, e) in &scenario.inputs {
            let Some(u) = position(
                self.c.inputs.iter().map(|(_, u)| u.name.as_str()),
                &name.name,
            ) else {
                self.undefined(name, "input");
                continue;
            };
            written[u] = true;
            if let Some(id) = self.resolve(e, &names) {
                commands[u] = Some((id, name.span));
            }
        }
        (commands, written)
    }

    /// The recorded signals' names: the inputs, then the measured signals.
    fn recorded(&self) -> Vec<String> {
        let c = self.c;
        (c.inputs.iter())
            .map(|(_, u)| u.name.clone())
            .chain(c.sensors.iter().map(|(_, s)| s.name.clone()))
            .collect()
    }

    /// The noise's deviation on each recorded signal: the inputs, then the measured signals.
    fn noise(&mut self, scenario: &Scenario) -> Vec<f64> {
        let names = self.recorded();
        let mut noise = vec![0.0; names.len()];
        for n in &scenario.noise {
            match names.iter().position(|r| *r == n.name.name) {
                Some(k) => noise[k] = n.value,
                None => self.undefined(&n.name, "input or measured signal"),
            }
        }
        noise
    }

    /// The quantiser of each recorded signal, where the scenario gives one.
    fn quantisers(&mut self, scenario: &Scenario) -> Vec<Option<Quantiser>> {
        let names = self.recorded();
        let mut quantisers = vec![None; names.len()];
        for q in &scenario.quantised {
            match names.iter().position(|r| *r == q.name.name) {
                Some(k) => quantisers[k] = Some(q.how),
                None => self.undefined(&q.name, "input or measured signal"),
            }
        }
        quantisers
    }

    /// Puts each command into the others until none reads an input: a command still reading
    /// one after as many rounds as there are inputs reads itself.
    fn close_loops(&mut self, mut commands: Vec<Option<(Id, Span)>>, written: &[bool]) -> Vec<Id> {
        let c = self.c;
        for (u, (_, input)) in c.inputs.iter().enumerate() {
            if !written[u] {
                self.errors.push(Diagnostic::error(
                    Code::Undefined,
                    Span::new(0, 0),
                    format!("the scenario does not say what drives the input `{}`: add `input {} = ...`", input.name, input.name),
                ));
            }
        }
        if self.errors.has_errors() {
            return Vec::new();
        }
        let Some(mut done) = commands
            .iter()
            .map(|c| c.map(|(id, _)| id))
            .collect::<Option<Vec<Id>>>()
        else {
            return Vec::new();
        };
        for _ in 0..=c.inputs.len() {
            let snapshot = done.clone();
            let mut changed = false;
            for e in &mut done {
                let new = self.substitute_inputs(*e, &snapshot);
                changed |= new != *e;
                *e = new;
            }
            if !changed {
                break;
            }
        }
        for (u, e) in done.iter().enumerate() {
            if self.reads_inputs(*e) {
                let span = commands[u].take().map_or(Span::new(0, 0), |(_, s)| s);
                self.errors.push(
                    Diagnostic::error(
                        Code::AlgebraicLoop,
                        span,
                        format!(
                            "the input `{}` depends on itself at the same instant (through a measured signal or another input): an algebraic loop the simulation cannot close",
                            c.inputs.iter().nth(u).map_or("", |(_, i)| i.name.as_str())
                        ),
                    )
                    .with_help("read a signal the input does not act on at once, or filter the loop"),
                );
            }
        }
        done
    }

    fn finish(
        mut self,
        scenario: &Scenario,
        commands: &[Id],
        noise: Vec<f64>,
    ) -> Result<Plant, Diagnostics> {
        let c = self.c;
        let rhs: Vec<Id> = self
            .rhs
            .clone()
            .into_iter()
            .map(|e| self.substitute_inputs(e, commands))
            .collect();
        let measured: Vec<Id> = self
            .measured
            .clone()
            .into_iter()
            .map(|e| self.substitute_inputs(e, commands))
            .collect();
        let loop_residuals: Vec<Id> = self
            .loops
            .clone()
            .into_iter()
            .map(|(_, e)| self.substitute_inputs(e, commands))
            .collect();
        let mut recorded: Vec<Id> = commands.to_vec();
        recorded.extend(&measured);
        self.undifferentiable(&rhs, &recorded, &loop_residuals);
        // Each `int(..)` is a state of its own, after the model's.
        let mut roots = rhs.clone();
        roots.extend(&recorded);
        roots.extend(&loop_residuals);
        let mut ints: Vec<(Id, Id)> = Vec::new();
        let mut seen = 0;
        loop {
            let mut found = Vec::new();
            self.pool.visit_reachable(&roots, |id, node| {
                if let Node::Int(arg) = node {
                    found.push((id, arg));
                }
            });
            found.retain(|f| !ints.contains(f));
            if found.is_empty() || seen > 10_000 {
                break;
            }
            seen += found.len();
            roots.extend(found.iter().map(|&(_, arg)| arg));
            ints.extend(found);
        }
        let mut state_names: Vec<String> = (c.states.iter().take(c.model_states()))
            .map(|(_, s)| s.name.clone())
            .collect();
        let model_states = state_names.len();
        let integrals: FastMap<Id, usize> = ints
            .iter()
            .enumerate()
            .map(|(i, &(id, _))| (id, model_states + i))
            .collect();
        state_names.extend((1..=ints.len()).map(|i| format!("int{i}")));
        let mut derivative_roots = rhs;
        derivative_roots.extend(ints.iter().map(|&(_, arg)| arg));
        let params = self.params(scenario);
        let initial = self.initial(scenario, state_names.len());
        let recorded_names: Vec<String> = c
            .inputs
            .iter()
            .map(|(_, u)| u.name.clone())
            .chain(c.sensors.iter().map(|(_, s)| s.name.clone()))
            .collect();
        if self.errors.has_errors() {
            self.errors.sort();
            return Err(self.errors);
        }
        let mut breaks: Vec<f64> = scenario
            .faults
            .iter()
            .flat_map(|f| f.onset.breaks())
            .collect();
        breaks.retain(|&b| b > 0.0 && b < scenario.duration);
        breaks.sort_by(f64::total_cmp);
        breaks.dedup();
        Ok(Plant {
            state_names,
            model_states,
            derivative: Tape::new(&self.pool, &derivative_roots),
            recorded: Tape::new(&self.pool, &recorded),
            recorded_names,
            loop_names: self.loops.iter().map(|(name, _)| name.clone()).collect(),
            loops: Tape::new(&self.pool, &loop_residuals),
            inputs: c.inputs.len(),
            integrals,
            params,
            faults: self.faults,
            initial,
            noise,
            quantisers: Vec::new(),
            breaks,
        })
    }

    fn params(&mut self, scenario: &Scenario) -> Vec<Course> {
        let mut params: Vec<Course> = self
            .c
            .parameters
            .iter()
            .map(|(_, p)| Course {
                nominal: p.value,
                changes: Vec::new(),
            })
            .collect();
        for f in &scenario.faults {
            if let FaultTarget::Parameter(name) = &f.target {
                let found = position(
                    self.c.parameters.iter().map(|(_, p)| p.name.as_str()),
                    &name.name,
                );
                match (found, self.constant(&f.size)) {
                    (Some(k), Some(v)) => params[k].changes.push((f.onset, v)),
                    (None, _) => self.undefined(name, "parameter"),
                    _ => {}
                }
            }
        }
        params
    }

    fn initial(&mut self, scenario: &Scenario, n: usize) -> Vec<f64> {
        let mut x = vec![0.0; n];
        for s in &scenario.initial {
            match position(
                (self.c.states.iter().take(self.c.model_states())).map(|(_, st)| st.name.as_str()),
                &s.name.name,
            ) {
                Some(k) => x[k] = s.value,
                None => self.undefined(&s.name, "state (`p_NAME` of an I, `q_NAME` of a C)"),
            }
        }
        x
    }

    /// Reports a derivative of an input that could not be taken: the input reads a measured
    /// signal that goes through a nonlinear algebraic loop, whose unknown has no expression
    /// to differentiate.
    fn undifferentiable(&mut self, rhs: &[Id], recorded: &[Id], loops: &[Id]) {
        let mut roots = rhs.to_vec();
        roots.extend(recorded);
        roots.extend(loops);
        let mut left = false;
        self.pool.visit_reachable(&roots, |_, node| {
            left |= matches!(node, Node::Leaf(P::InputDer(..)));
        });
        if left {
            let names: Vec<String> = self.loops.iter().map(|(n, _)| format!("`{n}`")).collect();
            self.errors.push(
                Diagnostic::error(
                    Code::Refused,
                    Span::new(0, 0),
                    format!(
                        "the model needs the derivative of an input that reads a measured signal through the nonlinear algebraic loop unknown(s) {}, which bgc solves numerically and cannot differentiate",
                        names.join(", ")
                    ),
                )
                .with_help("drive that input from signals outside the loop, or filter the signal it reads"),
            );
        }
    }

    /// `e` with input placeholders replaced by `commands` (derivatives differentiated).
    fn substitute_inputs(&mut self, e: Id, commands: &[Id]) -> Id {
        let mut derivatives: HashMap<(u32, u32), Option<Id>> = HashMap::new();
        let rhs = self.rhs.clone();
        let mut wanted = Vec::new();
        self.pool.visit_reachable(&[e], |_, node| {
            if let Node::Leaf(P::InputDer(u, n)) = node {
                wanted.push((u, n));
            }
        });
        for (u, n) in wanted {
            let command = commands[u as usize];
            if self.reads_inputs(command) {
                continue;
            }
            let d = nth_derivative(&mut self.pool, &rhs, command, n);
            derivatives.insert((u, n), d);
        }
        self.pool.substitute(e, &mut |_, leaf| match leaf {
            P::Input(u) => Some(commands[u as usize]),
            P::InputDer(u, n) => derivatives.get(&(u, n)).copied().flatten(),
            _ => None,
        })
    }

    fn reads_inputs(&self, e: Id) -> bool {
        self.pool
            .leaves(e)
            .iter()
            .any(|l| matches!(l, P::Input(_) | P::InputDer(..)))
    }

    /// A scenario expression over the plant's leaves, or `None` after reporting why not.
    fn resolve(&mut self, e: &AstExpr, names: &Names<'_>) -> Option<Id> {
        Some(match e {
            AstExpr::Num(v) => self.pool.num(*v),
            AstExpr::Leaf(name) => match names.find(&name.name) {
                Some(Name::Time) => self.pool.leaf(P::Time),
                Some(Name::Let(id)) => id,
                Some(Name::Parameter(k)) => {
                    let v = self
                        .c
                        .parameters
                        .iter()
                        .nth(k)
                        .map_or(f64::NAN, |(_, p)| p.value);
                    self.pool.num(v)
                }
                Some(Name::Input(u)) => self.pool.leaf(P::Input(u as u32)),
                Some(Name::Sensor(s)) => self.measured[s],
                None => {
                    self.undefined(
                        name,
                        "name (a `let`, input, parameter, measured signal or `t`)",
                    );
                    return None;
                }
            },
            AstExpr::Neg(a) => {
                let a = self.resolve(a, names)?;
                self.pool.neg(a)
            }
            AstExpr::Binary(op, a, b) => {
                let (a, b) = (self.resolve(a, names)?, self.resolve(b, names)?);
                self.pool.binary(*op, a, b)
            }
            AstExpr::Call(f, args) => {
                let args: Option<Vec<Id>> = args.iter().map(|a| self.resolve(a, names)).collect();
                self.pool.call(*f, &args?)
            }
            AstExpr::Der(a, n) => {
                let a = self.resolve(a, names)?;
                let rhs = self.rhs.clone();
                nth_derivative(&mut self.pool, &rhs, a, *n)?
            }
            AstExpr::Int(a) => {
                let a = self.resolve(a, names)?;
                self.pool.int(a)
            }
        })
    }

    /// A constant expression's value: numbers and the model's parameters (nominal).
    fn constant(&mut self, e: &AstExpr) -> Option<f64> {
        let names = Names {
            c: self.c,
            lets: HashMap::new(),
        };
        let id = self.resolve(e, &names)?;
        match self.pool.node(id) {
            Node::Num(bits) if f64::from_bits(bits).is_finite() => Some(f64::from_bits(bits)),
            _ => {
                self.errors.push(Diagnostic::error(
                    Code::BadValue,
                    span_of(e),
                    "a fault's size must be a constant: numbers and parameters only",
                ));
                None
            }
        }
    }

    fn undefined(&mut self, name: &Ident, what: &str) {
        let c = self.c;
        // The model's names a scenario can use, for "did you mean".
        let names: Vec<&str> = (c.parameters.values().map(|p| p.name.as_str()))
            .chain(c.inputs.values().map(|u| u.name.as_str()))
            .chain(c.sensors.values().map(|s| s.name.as_str()))
            .chain(
                c.states
                    .values()
                    .take(c.model_states())
                    .map(|s| s.name.as_str()),
            )
            .collect();
        let near = bondgraph_core::closest(&name.name, names.into_iter());
        let mut d = Diagnostic::error(
            Code::Undefined,
            name.span,
            format!(
                "`{}` is not {} {what} of `{}`",
                name.name,
                article(what),
                c.name
            ),
        )
        .with_label(format!("expected {} {what}", article(what)));
        if let Some(near) = near {
            d = d.with_help(format!("did you mean `{near}`?"));
        }
        self.errors.push(d);
    }
}

/// `e` with each factor of an integral that holds a faulted parameter taken back inside it:
/// `int(p)/Je` as `int(p/Je)`. The product's expressions take parameters out of integrals
/// (they are constant in time); a fault makes one change during the run, and then it scales
/// what is integrated from then on, as the flow it weighs does, not what was integrated
/// before.
fn inside_integrals(pool: &mut Pool<P>, e: Id) -> Id {
    if !pool.leaves(e).iter().any(|l| matches!(l, P::Param(_))) {
        return e;
    }
    let mut order = Vec::new();
    pool.visit_reachable(&[e], |id, _| order.push(id));
    let mut new: FastMap<Id, Id> = FastMap::default();
    // Numbers and faulted parameters: constant factors, taken in along with the parameters.
    let faulted = |pool: &Pool<P>, x: Id| pool.leaves(x).iter().all(|l| matches!(l, P::Param(_)));
    for id in order {
        let m = |x: Id| new.get(&x).copied().unwrap_or(x);
        let out = match pool.node(id) {
            Node::Num(_) | Node::Leaf(_) => id,
            Node::Neg(a) => match pool.node(m(a)) {
                Node::Int(x) => {
                    let y = pool.neg(x);
                    pool.int(y)
                }
                _ => pool.neg(m(a)),
            },
            Node::Binary(op, a, b) => {
                let (a, b) = (m(a), m(b));
                match (op, pool.node(a), pool.node(b)) {
                    (BinOp::Mul, Node::Int(x), _) if faulted(pool, b) => {
                        let y = pool.mul(x, b);
                        pool.int(y)
                    }
                    (BinOp::Mul, _, Node::Int(x)) if faulted(pool, a) => {
                        let y = pool.mul(a, x);
                        pool.int(y)
                    }
                    (BinOp::Div, Node::Int(x), _) if faulted(pool, b) => {
                        let y = pool.div(x, b);
                        pool.int(y)
                    }
                    _ => pool.binary(op, a, b),
                }
            }
            Node::Call1(f, a) => pool.call(f, &[m(a)]),
            Node::Call2(f, a, b) => pool.call(f, &[m(a), m(b)]),
            Node::Int(a) => pool.int(m(a)),
        };
        new.insert(id, out);
    }
    new.get(&e).copied().unwrap_or(e)
}

fn article(what: &str) -> &'static str {
    if what.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    }
}

/// `signal` with a fault applied: `signal * gain` or `signal + offset`.
fn apply(pool: &mut Pool<P>, signal: Id, mode: FaultMode, fault: Id) -> Id {
    match mode {
        FaultMode::Additive => pool.add(signal, fault),
        FaultMode::Multiplicative => pool.mul(signal, fault),
    }
}

/// The n-th time derivative of `e` along the state equations `rhs`.
fn nth_derivative(pool: &mut Pool<P>, rhs: &[Id], e: Id, n: u32) -> Option<Id> {
    let mut d = Derivatives::new(|p: &mut Pool<P>, leaf: P| match leaf {
        P::State(k) => rhs.get(k.index()).copied(),
        P::Input(u) => Some(p.leaf(P::InputDer(u, 1))),
        P::InputDer(u, m) => Some(p.leaf(P::InputDer(u, m + 1))),
        // Faults and parameters are piecewise constant or slow: their course is not differentiated.
        P::Param(_) | P::Fault(_) => Some(p.num(0.0)),
        P::Time => Some(p.num(1.0)),
        // An implicit unknown has no expression to differentiate.
        P::Loop(_) => None,
    });
    let mut e = e;
    for _ in 0..n {
        e = d.of(pool, e)?;
    }
    Some(e)
}

fn position<'a>(mut names: impl Iterator<Item = &'a str>, name: &str) -> Option<usize> {
    names.position(|n| n == name)
}

/// Where an expression was written: its first name, or nothing for a bare number.
fn span_of(e: &AstExpr) -> Span {
    match e {
        AstExpr::Leaf(name) => name.span,
        AstExpr::Neg(a) | AstExpr::Der(a, _) | AstExpr::Int(a) => span_of(a),
        AstExpr::Binary(_, a, b) => {
            let (a, b) = (span_of(a), span_of(b));
            if a.end == 0 {
                b
            } else {
                a
            }
        }
        AstExpr::Call(_, args) => args
            .iter()
            .map(span_of)
            .find(|s| s.end > 0)
            .unwrap_or_default(),
        AstExpr::Num(_) => Span::default(),
    }
}
