//! The product lowered to the residual program: slots for what the residuals read, `int(..)`
//! replaced by slots, auxiliary signals by their definitions, the copy's integrals by its
//! states.

use std::collections::HashMap;

use super::{Channel, Code, CopyRates, Evaluation, Fill, Leaf, Program, Raw, Residual};
use super::{CopyInput, CopyState, Sensitivity, Slot, Source};
use crate::index::Idx as _;
use crate::product::{Arena, Auxiliary, Compiled, Expr, Handle, ModelCopy, Quantity, Root};
use crate::product::{Readings, Realisation, Signal, Symbol};
use crate::symbolic::{Node, Pool};

impl Compiled {
    /// The residual program of the ARRs as realised (see [`Program`]).
    pub fn program(&self) -> Program {
        let readings = self.readings();
        let raw = raw_signals(self, &readings);
        let (channels, differentiated) = channels(&raw, &readings);
        let mut lower = Lowering {
            c: self,
            code: Pool::default(),
            slots: Arena::default(),
            slot: HashMap::new(),
            nonlinear: readings.nonlinear.clone(),
            auxiliary: HashMap::new(),
            residual_memo: HashMap::new(),
            copy_memo: HashMap::new(),
        };
        lower.slots(&readings, &raw, &channels);
        let residuals = (self.arrs.iter())
            .map(|a| Residual {
                name: a.name.clone(),
                code: lower.residual(a.evaluated()),
                evaluation: match a.realisation {
                    Realisation::Direct => Evaluation::Direct,
                    Realisation::Integrated(_) => Evaluation::Integrated,
                },
            })
            .collect();
        let mut sensitivities = Vec::new();
        for (k, arr) in self.arrs.iter().enumerate() {
            for &(parameter, e) in arr.sensitivities.iter().flatten() {
                let code = lower.residual(e);
                sensitivities.push(Sensitivity {
                    residual: k,
                    parameter,
                    code,
                });
            }
        }
        let roots: Vec<Expr> = self.arrs.iter().map(|a| a.evaluated()).collect();
        let named = (self.auxiliary_derivatives_read(&roots).into_iter())
            .map(|(a, n)| {
                let aux = &self.auxiliaries[a];
                let name = match n {
                    0 => aux.name.clone(),
                    n => format!("{}_d{n}", aux.name),
                };
                (lower.auxiliary(a, n), name)
            })
            .collect();
        let copy = (readings.copy.as_ref()).map(|copy| lower.copy(copy, &raw));
        Program {
            raw,
            channels,
            differentiated,
            slots: lower.slots,
            code: lower.code,
            residuals,
            sensitivities,
            named,
            copy,
        }
    }
}

/// The raw signals the residuals read, in [`Signal`] order.
fn raw_signals(c: &Compiled, readings: &Readings) -> Arena<Raw> {
    let mut raw = Arena::default();
    for &(signal, order) in &readings.raw {
        let name = match signal {
            Signal::Input(u) => c.inputs[u].name.clone(),
            Signal::Sensor(h) => c.sensors[h].name.clone(),
        };
        raw.push(Raw {
            signal,
            name,
            order,
        });
    }
    raw
}

/// The bank's channels: the raw signals whose derivatives are read first (the bank
/// differentiates only those), then the other raw signals, then the integrals.
fn channels(raw: &Arena<Raw>, readings: &Readings) -> (Arena<Channel>, usize) {
    let mut channels = Arena::default();
    let differentiated = raw.values().filter(|r| r.order > 0).count();
    let ranked =
        (raw.iter().filter(|(_, r)| r.order > 0)).chain(raw.iter().filter(|(_, r)| r.order == 0));
    for (h, r) in ranked {
        channels.push(Channel {
            source: Source::Raw(h),
            order: r.order,
        });
    }
    for &s in &readings.integrated {
        if let Some(h) = raw.find(|r| r.signal == s) {
            channels.push(Channel {
                source: Source::Integral(h),
                order: 0,
            });
        }
    }
    (channels, differentiated)
}

/// Lowers product expressions into the program's pool.
struct Lowering<'c> {
    c: &'c Compiled,
    code: Pool<Leaf>,
    slots: Arena<Slot>,
    slot: HashMap<Quantity, Handle<Slot>>,
    nonlinear: Vec<Expr>,
    auxiliary: HashMap<(Handle<Auxiliary>, u32), Code>,
    /// What each product node became in the residuals, and in the copy's rates: the same
    /// state is a slot in one and a state in the other.
    residual_memo: HashMap<Expr, Code>,
    copy_memo: HashMap<Expr, Code>,
}

/// Where an expression is lowered.
#[derive(Clone, Copy)]
enum Context<'a> {
    Residual,
    Copy(&'a ModelCopy),
}

impl Lowering<'_> {
    /// One slot per quantity read, in the readings' order; a nonlinear integral's integrand
    /// reads the slots before it.
    fn slots(&mut self, readings: &Readings, raw: &Arena<Raw>, channels: &Arena<Channel>) {
        let channel = |source: Source| channels.find(|c| c.source == source);
        let raw_of = |s: Signal| raw.find(|r| r.signal == s);
        for &quantity in &readings.quantities {
            let fill = match quantity {
                Quantity::Derivative(s, order) => raw_of(s)
                    .and_then(|h| channel(Source::Raw(h)))
                    .map(|channel| Fill::Estimate { channel, order }),
                Quantity::Integral(s) => raw_of(s)
                    .and_then(|h| channel(Source::Integral(h)))
                    .map(|channel| Fill::Estimate { channel, order: 0 }),
                // Filled below, once every slot it may read exists.
                Quantity::Nonlinear(_) | Quantity::Root(_) => Some(Fill::Simulated(CopyState(0))),
                Quantity::Simulated(k) => (readings.copy.as_ref())
                    .and_then(|copy| copy.states.iter().position(|&s| s == k))
                    .map(|j| Fill::Simulated(CopyState::new(j))),
            };
            // Every signal read has a raw signal and a channel (see `channels`).
            let Some(fill) = fill else { continue };
            let h = self.slots.push(Slot { quantity, fill });
            self.slot.insert(quantity, h);
        }
        for &quantity in &readings.quantities {
            let Quantity::Root(h) = quantity else {
                continue;
            };
            let root = &self.c.roots[h];
            let (residual, slope) = (self.residual(root.residual), self.residual(root.slope));
            if let Some(&slot) = self.slot.get(&quantity) {
                self.slots.get_mut(slot).fill = Fill::Root { residual, slope };
            }
        }
        for (k, &integrand) in readings.nonlinear.iter().enumerate() {
            let code = self.residual(integrand);
            if let Some(&h) = self.slot.get(&Quantity::Nonlinear(k)) {
                self.slots.get_mut(h).fill = Fill::Integral(code);
            }
        }
    }

    fn residual(&mut self, root: Expr) -> Code {
        self.lower(root, Context::Residual)
    }

    /// The copy's rates, over its states and inputs.
    fn copy(&mut self, copy: &ModelCopy, raw: &Arena<Raw>) -> CopyRates {
        let rates = (copy.rates.iter())
            .map(|&e| self.lower(e, Context::Copy(copy)))
            .collect();
        let names = (copy.states.iter().map(|&s| self.c.states[s].name.clone()))
            .chain((1..=copy.integrals.len()).map(|k| format!("int{k}")))
            .collect();
        let inputs = (copy.inputs.iter())
            .filter_map(|&u| raw.find(|r| r.signal == u))
            .collect();
        CopyRates {
            rates,
            names,
            inputs,
        }
    }

    /// A root's `n`-th derivative (n ≥ 1), an expression of the root and the signals.
    fn root_derivative(&mut self, h: Handle<Root>, n: u32) -> Code {
        match self.c.roots[h].derivative(n) {
            Some(e) => self.residual(e),
            None => self.code.num(f64::NAN),
        }
    }

    /// The auxiliary signal's `n`-th derivative, lowered once.
    fn auxiliary(&mut self, a: Handle<Auxiliary>, n: u32) -> Code {
        if let Some(&code) = self.auxiliary.get(&(a, n)) {
            return code;
        }
        let c = self.c;
        let code = match c.auxiliaries[a].derivative(n) {
            Some(e) => self.residual(e),
            None => self.code.num(f64::NAN),
        };
        self.auxiliary.insert((a, n), code);
        code
    }

    fn memo(&self, cx: Context<'_>) -> &HashMap<Expr, Code> {
        match cx {
            Context::Residual => &self.residual_memo,
            Context::Copy(..) => &self.copy_memo,
        }
    }

    /// `root` in the program's pool, children first, each node once per context.
    fn lower(&mut self, root: Expr, cx: Context<'_>) -> Code {
        let c = self.c;
        let order = c
            .exprs
            .reachable_unless(root, |id| self.memo(cx).contains_key(&id));
        for id in order {
            let code = self.node(c.exprs.node(id), cx);
            match cx {
                Context::Residual => self.residual_memo.insert(id, code),
                Context::Copy(..) => self.copy_memo.insert(id, code),
            };
        }
        self.get(root, cx)
    }

    /// What `e` became; every child is lowered before its parent.
    fn get(&mut self, e: Expr, cx: Context<'_>) -> Code {
        match self.memo(cx).get(&e) {
            Some(&code) => code,
            None => self.code.num(f64::NAN),
        }
    }

    fn node(&mut self, node: Node<Symbol>, cx: Context<'_>) -> Code {
        match node {
            Node::Num(bits) => self.code.num(f64::from_bits(bits)),
            Node::Leaf(s) => self.leaf(s, cx),
            Node::Neg(a) => {
                let a = self.get(a, cx);
                self.code.neg(a)
            }
            Node::Binary(op, a, b) => {
                let (a, b) = (self.get(a, cx), self.get(b, cx));
                self.code.binary(op, a, b)
            }
            Node::Call1(f, a) => {
                let a = self.get(a, cx);
                self.code.call(f, &[a])
            }
            Node::Call2(f, a, b) => {
                let (a, b) = (self.get(a, cx), self.get(b, cx));
                self.code.call(f, &[a, b])
            }
            Node::Int(a) => match cx {
                Context::Residual => self.integral(a),
                Context::Copy(copy) => match copy.integrals.iter().position(|&e| e == a) {
                    Some(k) => (self.code).leaf(Leaf::State(CopyState::new(copy.states.len() + k))),
                    None => self.code.num(f64::NAN),
                },
            },
        }
    }

    /// A product leaf. What a context cannot read (a loop unknown; a derivative of an input
    /// in the copy) never occurs in it; it would be NaN, which no residual passes for zero.
    fn leaf(&mut self, s: Symbol, cx: Context<'_>) -> Code {
        let slot = |this: &mut Self, q: Quantity| match this.slot.get(&q) {
            Some(&h) => this.code.leaf(Leaf::Slot(h)),
            // A signal read only under an integral: never evaluated.
            None => this.code.num(f64::NAN),
        };
        match (s, cx) {
            (Symbol::Parameter(p), _) => self.code.leaf(Leaf::Parameter(p)),
            (Symbol::Time, _) => self.code.leaf(Leaf::Time),
            (Symbol::State(k), Context::Copy(copy)) => {
                match copy.states.iter().position(|&s| s == k) {
                    Some(j) => self.code.leaf(Leaf::State(CopyState::new(j))),
                    None => self.code.num(f64::NAN),
                }
            }
            (Symbol::Sensor(h, 0), Context::Copy(copy)) => {
                match copy.inputs.iter().position(|&i| i == Signal::Sensor(h)) {
                    Some(j) => self.code.leaf(Leaf::Input(CopyInput::new(j))),
                    None => self.code.num(f64::NAN),
                }
            }
            (Symbol::Input(u, 0), Context::Copy(copy)) => {
                match copy.inputs.iter().position(|&i| i == Signal::Input(u)) {
                    Some(j) => self.code.leaf(Leaf::Input(CopyInput::new(j))),
                    None => self.code.num(f64::NAN),
                }
            }
            (Symbol::Input(u, n), Context::Residual) => {
                slot(self, Quantity::Derivative(Signal::Input(u), n))
            }
            (Symbol::Sensor(h, n), Context::Residual) => {
                slot(self, Quantity::Derivative(Signal::Sensor(h), n))
            }
            (Symbol::State(k), Context::Residual) => slot(self, Quantity::Simulated(k)),
            (Symbol::Auxiliary(a, n), Context::Residual) => self.auxiliary(a, n),
            (Symbol::Root(h, 0), Context::Residual) => slot(self, Quantity::Root(h)),
            (Symbol::Root(h, n), Context::Residual) => self.root_derivative(h, n),
            _ => self.code.num(f64::NAN),
        }
    }

    /// `int(a)` in a residual: its own slot, or the combination of the signals' integrals
    /// it is.
    fn integral(&mut self, a: Expr) -> Code {
        if let Some(k) = self.nonlinear.iter().position(|&e| e == a) {
            return match self.slot.get(&Quantity::Nonlinear(k)) {
                Some(&h) => self.code.leaf(Leaf::Slot(h)),
                None => self.code.num(f64::NAN),
            };
        }
        let Some(terms) = self.c.linear_terms(a) else {
            return self.code.num(f64::NAN);
        };
        let mut signed = Vec::with_capacity(terms.len());
        for (plus, coefficient, signal) in terms {
            let Some(&h) = self.slot.get(&Quantity::Integral(signal)) else {
                return self.code.num(f64::NAN);
            };
            let integral = self.code.leaf(Leaf::Slot(h));
            let term = match coefficient {
                Some(k) => {
                    let k = self.get(k, Context::Residual);
                    self.code.mul(k, integral)
                }
                None => integral,
            };
            signed.push((plus, term));
        }
        self.code.signed_sum(&signed)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::super::Leaf;
    use crate::product::{Compiled, Expr, Quantity, Signal, Symbol};
    use crate::symbolic::{Evaluator, Node};
    use crate::{compile, Options, ResidualSet};

    /// An arbitrary value for slot `k`, away from 0 and from the values of the others.
    fn arbitrary(k: usize) -> f64 {
        0.3 + ((k as f64 * 0.618_033_988_7) % 1.0) * 1.7
    }

    /// The product's evaluated ARR `e` with every quantity at the value of its slot, each
    /// `int(..)` as the combination of integral slots it is (or its own slot), each auxiliary
    /// signal at its definition's value: what the program must compute, by the product's
    /// expressions and evaluator rather than the lowering.
    fn product_value(c: &Compiled, e: Expr, slot: &dyn Fn(Quantity) -> f64) -> f64 {
        let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
        let param = |p: crate::product::Handle<crate::product::Parameter>| params[p.index()];
        let mut auxiliary: HashMap<(usize, u32), f64> = HashMap::new();
        let readings = c.readings();
        let leaf = |aux: &HashMap<(usize, u32), f64>, s: Symbol| match s {
            Symbol::Parameter(p) => param(p),
            Symbol::Input(u, n) => slot(Quantity::Derivative(Signal::Input(u), n)),
            Symbol::Sensor(h, n) => slot(Quantity::Derivative(Signal::Sensor(h), n)),
            Symbol::State(k) => slot(Quantity::Simulated(k)),
            Symbol::Auxiliary(a, n) => aux[&(a.index(), n)],
            Symbol::Root(h, 0) => slot(Quantity::Root(h)),
            // Over the roots' values and signals only.
            Symbol::Root(h, n) => {
                let d = c.roots[h].derivative(n);
                d.map_or(f64::NAN, |d| {
                    Evaluator::new(&c.exprs, |s| match s {
                        Symbol::Parameter(p) => param(p),
                        Symbol::Input(u, n) => slot(Quantity::Derivative(Signal::Input(u), n)),
                        Symbol::Sensor(h, n) => slot(Quantity::Derivative(Signal::Sensor(h), n)),
                        Symbol::Root(h, 0) => slot(Quantity::Root(h)),
                        _ => f64::NAN,
                    })
                    .value(d)
                })
            }
            Symbol::Time | Symbol::Loop(_) => f64::NAN,
        };
        let integrals = |root: Expr| {
            let mut values = HashMap::new();
            c.exprs.visit_reachable(&[root], |id, node| {
                let Node::Int(arg) = node else { return };
                let value = match readings.nonlinear.iter().position(|&e| e == arg) {
                    Some(k) => slot(Quantity::Nonlinear(k)),
                    None => (c.linear_terms(arg).unwrap_or_default().into_iter())
                        .map(|(plus, k, s)| {
                            let k = k.map_or(1.0, |k| {
                                Evaluator::new(&c.exprs, |s| match s {
                                    Symbol::Parameter(p) => param(p),
                                    _ => f64::NAN,
                                })
                                .value(k)
                            });
                            let v = k * slot(Quantity::Integral(s));
                            if plus {
                                v
                            } else {
                                -v
                            }
                        })
                        .sum(),
                };
                values.insert(id, value);
            });
            values
        };
        for (a, aux) in c.auxiliaries.iter() {
            for (n, &d) in (0u32..).zip(&aux.derivatives) {
                let v = Evaluator::new(&c.exprs, |s| leaf(&auxiliary, s))
                    .with_integrals(integrals(d))
                    .value(d);
                auxiliary.insert((a.index(), n), v);
            }
        }
        Evaluator::new(&c.exprs, |s| leaf(&auxiliary, s))
            .with_integrals(integrals(e))
            .value(e)
    }

    /// On every model, with one residual per detector and with `best`, each residual (and
    /// each sensitivity) of the program takes the value of the product's evaluated ARR (and
    /// sensitivity) at arbitrary values of what it reads: the lowering (slots for integrals, auxiliaries inlined, shared nodes) changes
    /// nothing.
    #[test]
    fn the_program_computes_the_products_residuals() {
        let mut checked = 0;
        for entry in std::fs::read_dir("../../models").expect("models") {
            let path = entry.expect("entry").path();
            let text = std::fs::read_to_string(&path).expect("model");
            for residuals in [ResidualSet::PerSensor, ResidualSet::Best] {
                let options = Options {
                    residuals,
                    ..Options::default()
                };
                let c = compile(&text, "m.bg", &options).expect("valid").compiled;
                let program = c.program();
                let params: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
                let slot = |q: Quantity| program.slot(q).map_or(f64::NAN, |h| arbitrary(h.index()));
                let sensitivities = (c.arrs.iter())
                    .flat_map(|a| a.sensitivities.iter().flatten().map(move |&(_, e)| (a, e)));
                let pairs = (c.arrs.iter().map(|a| (a, a.evaluated())))
                    .zip(program.residuals.iter().map(|r| r.code))
                    .chain(sensitivities.zip(program.sensitivities.iter().map(|s| s.code)));
                for ((arr, e), code) in pairs {
                    let want = product_value(&c, e, &slot);
                    let got = Evaluator::new(&program.code, |l| match l {
                        Leaf::Slot(h) => arbitrary(h.index()),
                        Leaf::Parameter(p) => params[p.index()],
                        _ => f64::NAN,
                    })
                    .value(code);
                    // Arbitrary values may lie outside a law's domain (the pump's square
                    // roots of a pressure): both are then not a number, and agree.
                    if got.is_nan() && want.is_nan() {
                        continue;
                    }
                    let scale = want.abs().max(1.0);
                    assert!(
                        (got - want).abs() <= 1e-9 * scale,
                        "{}: {}: program {got}, product {want}",
                        path.display(),
                        arr.name
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 40, "{checked} residuals");
    }
}
