//! What a residual generator must estimate from a bench's samples to evaluate the ARRs: each
//! signal's value and derivatives, integrals of signals, and integrals of expressions that are
//! not linear in the signals. The Rust generator and `bgc residuals` read the same list, so
//! the two compute the same numbers.

use std::collections::{BTreeMap, BTreeSet};

use super::{Compiled, Expr, Handle, ResidualForm, Root, Signal, State, Symbol};
use crate::expr::BinOp;
use crate::symbolic::Node;

/// One quantity the ARRs read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Quantity {
    /// The n-th time derivative of a signal (0: the signal).
    Derivative(Signal, u32),
    /// A signal's integral from the start of the record.
    Integral(Signal),
    /// The integral from the start of the record of [`Readings::nonlinear`]'s k-th expression.
    Nonlinear(usize),
    /// A state of the copy of the model that simulated residuals run ([`Readings::copy`]).
    Simulated(Handle<State>),
    /// A root the ARRs read, solved at each sample from the quantities before it.
    Root(Handle<Root>),
}

/// The copy of the model that simulated residuals run: the model's states, then one per
/// `int(..)` its state equations hold, integrated from zero (the model at rest) with the
/// inputs as recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelCopy {
    /// The states it runs, in [`Compiled::states`] order: those the simulated residuals
    /// read, directly or through the rates of others (a partial copy's own, not the
    /// model's it leaves aside).
    pub states: Vec<Handle<State>>,
    /// Each state's rate, over parameters, input values, time, the model's states
    /// ([`Symbol::State`]) and the integrals of [`ModelCopy::integrals`] (as `int(..)` nodes):
    /// the state equations of [`ModelCopy::states`], then each integral's argument.
    pub rates: Vec<Expr>,
    /// The arguments of the `int(..)` the state equations hold, in the order of their states.
    pub integrals: Vec<Expr>,
    /// The signals the rates read, in [`Signal`] order: the inputs, then the measured
    /// signals a partial copy reads.
    pub inputs: Vec<Signal>,
}

/// Everything the ARRs read from a bench, in a fixed order.
#[derive(Clone, Debug, PartialEq)]
pub struct Readings {
    /// Per signal (in [`Signal`] order) its derivatives by order, then its integral if read;
    /// then the roots; then the nonlinear integrals.
    pub quantities: Vec<Quantity>,
    /// Each raw signal the ARRs read, with the highest derivative read.
    pub raw: Vec<(Signal, u32)>,
    /// The signals whose integral is read, in order.
    pub integrated: Vec<Signal>,
    /// The arguments of `int(..)` that are not linear combinations of signals.
    pub nonlinear: Vec<Expr>,
    /// The copy of the model, when a simulated residual reads it.
    pub copy: Option<ModelCopy>,
}

/// One term `± coefficient · signal` of a linear combination (no coefficient: 1).
pub type LinearTerm = (bool, Option<Expr>, Signal);

impl Compiled {
    /// What the ARRs read from a bench.
    pub fn readings(&self) -> Readings {
        let mut uses: BTreeMap<Signal, (BTreeSet<u32>, bool)> = BTreeMap::new();
        for arr in &self.arrs {
            for r in arr.evaluated_reads().0 {
                let entry = uses.entry(r.signal).or_default();
                entry.0.extend(r.orders.iter().copied());
                entry.1 |= r.integral;
            }
        }
        let mut nonlinear: Vec<Expr> = Vec::new();
        for arr in &self.arrs {
            for &e in arr.evaluated_reads().1 {
                if self.linear_terms(e).is_none() && !nonlinear.contains(&e) {
                    nonlinear.push(e);
                }
            }
        }
        let mut quantities = Vec::new();
        let mut raw = Vec::new();
        let mut integrated = Vec::new();
        for (&signal, (orders, integral)) in &uses {
            raw.push((signal, orders.iter().copied().max().unwrap_or(0)));
            quantities.extend(orders.iter().map(|&n| Quantity::Derivative(signal, n)));
            if *integral {
                quantities.push(Quantity::Integral(signal));
                integrated.push(signal);
            }
        }
        // A root's law reads signals (before it) and earlier roots; an integral may read a
        // root (after it).
        let evaluated: Vec<Expr> = self.arrs.iter().map(|a| a.evaluated()).collect();
        quantities.extend(self.roots_read(&evaluated).into_iter().map(Quantity::Root));
        quantities.extend((0..nonlinear.len()).map(Quantity::Nonlinear));
        let copy = self.copy();
        if copy.is_some() {
            let roots: Vec<Expr> = (self.arrs.iter())
                .filter(|a| a.form == ResidualForm::Simulated)
                .map(|a| a.expr)
                .collect();
            let mut states: BTreeSet<Handle<State>> = BTreeSet::new();
            for &r in &roots {
                states.extend(self.exprs.leaves(r).into_iter().filter_map(|l| match l {
                    Symbol::State(k) => Some(k),
                    _ => None,
                }));
            }
            quantities.extend(states.into_iter().map(Quantity::Simulated));
        }
        Readings {
            quantities,
            raw,
            integrated,
            nonlinear,
            copy,
        }
    }

    /// The copy of the model simulated residuals run, if one does and the state equations
    /// were written.
    fn copy(&self) -> Option<ModelCopy> {
        if !self.arrs.iter().any(|a| a.form == ResidualForm::Simulated) {
            return None;
        }
        let space = self.state_space.as_ref()?;
        let mut all = vec![None; self.states.len()];
        let copies = space.copies.iter().flat_map(|c| &c.equations);
        for &(k, e) in space.equations.iter().chain(copies) {
            all[k.index()] = Some(e);
        }
        let states = self.copied_states(&all);
        let mut rates: Vec<Expr> = (states.iter())
            .map(|k| all[k.index()])
            .collect::<Option<_>>()?;
        let mut integrals: Vec<Expr> = Vec::new();
        self.exprs.visit_reachable(&rates, |_, node| {
            if let Node::Int(arg) = node {
                if !integrals.contains(&arg) {
                    integrals.push(arg);
                }
            }
        });
        rates.extend(integrals.iter().copied());
        let mut inputs: BTreeSet<Signal> = BTreeSet::new();
        for &r in &rates {
            inputs.extend(self.exprs.leaves(r).into_iter().filter_map(|l| match l {
                Symbol::Input(u, _) => Some(Signal::Input(u)),
                Symbol::Sensor(s, _) => Some(Signal::Sensor(s)),
                _ => None,
            }));
        }
        Some(ModelCopy {
            states,
            rates,
            integrals,
            inputs: inputs.into_iter().collect(),
        })
    }

    /// The states the simulated residuals read, directly or through the rates `rates` (by
    /// state) of those they read, in order.
    fn copied_states(&self, rates: &[Option<Expr>]) -> Vec<Handle<State>> {
        let mut read: BTreeSet<Handle<State>> = BTreeSet::new();
        let mut stack: Vec<Expr> = (self.arrs.iter())
            .filter(|a| a.form == ResidualForm::Simulated)
            .map(|a| a.expr)
            .collect();
        while let Some(e) = stack.pop() {
            for leaf in self.exprs.leaves(e) {
                if let Symbol::State(k) = leaf {
                    if read.insert(k) {
                        stack.extend(rates.get(k.index()).copied().flatten());
                    }
                }
            }
        }
        read.into_iter().collect()
    }

    /// `e` as `Σ ±cᵢ·signalᵢ` with constant `cᵢ` (parameters and numbers), if it is one: then
    /// `int(e) = Σ ±cᵢ·int(signalᵢ)`.
    pub fn linear_terms(&self, e: Expr) -> Option<Vec<LinearTerm>> {
        let constant = |e: Expr| {
            self.exprs
                .leaves(e)
                .iter()
                .all(|l| matches!(l, Symbol::Parameter(_)))
        };
        let signal = |x: Expr| match self.exprs.node(x) {
            Node::Leaf(Symbol::Input(u, 0)) => Some(Signal::Input(u)),
            Node::Leaf(Symbol::Sensor(s, 0)) => Some(Signal::Sensor(s)),
            _ => None,
        };
        let mut out = Vec::new();
        let mut stack = vec![(true, e)];
        while let Some((positive, e)) = stack.pop() {
            match self.exprs.node(e) {
                Node::Binary(BinOp::Add, a, b) => stack.extend([(positive, b), (positive, a)]),
                Node::Binary(BinOp::Sub, a, b) => stack.extend([(!positive, b), (positive, a)]),
                Node::Neg(a) => stack.push((!positive, a)),
                Node::Binary(BinOp::Mul, a, b) => match (signal(a), signal(b)) {
                    (_, Some(s)) if constant(a) => out.push((positive, Some(a), s)),
                    (Some(s), _) if constant(b) => out.push((positive, Some(b), s)),
                    _ => return None,
                },
                _ => out.push((positive, None, signal(e)?)),
            }
        }
        Some(out)
    }
}
