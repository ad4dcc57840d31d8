//! A sparser basis of ARRs: a combination of two ARRs that depends on fewer parameters than
//! either replaces the larger.
//!
//! Each detector's junction balance gives one ARR, but any combination of the ARRs is one
//! too, and the balance is not always the sparsest. Two capacitor nodes joined by a resistor
//! bridge, both voltages measured: each node's balance holds the whole bridge, while their
//! sum, the total current balance, holds none of it (what enters the bridge leaves it). A
//! fault of the bridge then shows in one residual instead of two.
//!
//! For each pair of ARRs and each measured or input signal that both hold linearly with
//! coefficients of parameters only, `c_j r_i - c_i r_j` removes that signal; divided by the
//! factors its terms share (a scale, which does not move its zeros), it replaces the one of
//! the two that depends on more parameters when it depends on fewer parameters than either.
//! The span of the ARRs is unchanged (both coefficients are non-zero). Bounded: at most
//! [`MAX_RELATIONS`] ARRs of at most [`MAX_TERMS`] terms each, products of at most
//! [`MAX_PRODUCT`] terms, and one replacement per dependence removed.

use std::collections::BTreeSet;

use super::eliminate::Constraint;
use super::sensitivity::dependences;
use crate::graph::{BondGraph, ParamId};
use crate::symbolic::{ExprId, Leaf, Node, Polynomial, Pool, Simplifier};

/// Models with more ARRs keep the basis elimination gave (a chain's ARRs are already local).
const MAX_RELATIONS: usize = 16;

/// The most terms a combination's two products may have together.
const MAX_PRODUCT: usize = 20_000;

/// The most terms an ARR may have to take part (larger ones are shown as they are).
const MAX_TERMS: usize = 4_000;

/// Replaces ARRs by sparser combinations of pairs, as long as one is found.
pub(super) fn sparsen(pool: &mut Pool, model: &BondGraph, relations: &mut [Constraint]) {
    let n = relations.len();
    if !(2..=MAX_RELATIONS).contains(&n) {
        return;
    }
    let mut simplifier = Simplifier::default();
    let polys: Vec<Polynomial> = relations
        .iter()
        .map(|r| simplifier.polynomial(pool, r.expr))
        .collect();
    // One that reads an auxiliary signal keeps its parameters inside it, out of the
    // dependences judged here: it is left as it is.
    let named = |r: &Constraint| {
        pool.leaves(r.expr)
            .iter()
            .any(|l| matches!(l, Leaf::Aux(..) | Leaf::Root(..)))
    };
    let small: Vec<bool> = polys
        .iter()
        .zip(relations.iter())
        .map(|(p, r)| p.terms() <= MAX_TERMS && !named(r))
        .collect();
    let mut polys: Vec<Option<Polynomial>> = polys
        .into_iter()
        .zip(&small)
        .map(|(p, &s)| s.then_some(p))
        .collect();
    let mut depends: Vec<BTreeSet<ParamId>> = relations
        .iter()
        .zip(&small)
        .map(|(r, &s)| {
            if s {
                dependences(pool, r.expr, model)
            } else {
                BTreeSet::new()
            }
        })
        .collect();
    // Each success removes at least one dependence: bounded by their total.
    let mut budget: usize = depends.iter().map(BTreeSet::len).sum();
    'search: while budget > 0 {
        budget -= 1;
        for i in 0..n {
            for j in i + 1..n {
                let (Some(pi), Some(pj)) = (&polys[i], &polys[j]) else {
                    continue;
                };
                let fewest = depends[i].len().min(depends[j].len());
                let Some((e, d)) = sparser(pool, model, &mut simplifier, pi, pj, fewest) else {
                    continue;
                };
                let (k, other) = if depends[i].len() > depends[j].len() {
                    (i, j)
                } else {
                    (j, i)
                };
                let merged: BTreeSet<usize> = relations[other].equations.clone();
                relations[k].expr = e;
                relations[k].equations.extend(merged);
                polys[k] = Some(simplifier.polynomial(pool, e));
                depends[k] = d;
                continue 'search;
            }
        }
        break;
    }
}

/// The first combination of `pi` and `pj` that removes a signal and depends on fewer than
/// `fewest` parameters, with its dependences.
fn sparser(
    pool: &mut Pool,
    model: &BondGraph,
    simplifier: &mut Simplifier,
    pi: &Polynomial,
    pj: &Polynomial,
    fewest: usize,
) -> Option<(ExprId, BTreeSet<ParamId>)> {
    for leaf in shared_signals(pool, pi, pj) {
        let (Some(ci), Some(cj)) = (coefficient(pool, pi, leaf), coefficient(pool, pj, leaf))
        else {
            continue;
        };
        if pi.terms() * cj.terms() + pj.terms() * ci.terms() > MAX_PRODUCT {
            continue;
        }
        let combined = pi.times(&cj).plus(&pj.times(&ci), -1.0);
        if combined.is_zero() {
            continue;
        }
        let e = combined.expr(pool);
        let e = simplifier.without_content(pool, e);
        let e = simplifier.without_scale(pool, e);
        let d = dependences(pool, e, model);
        if d.len() < fewest {
            return Some((e, d));
        }
    }
    None
}

/// The input and measured-signal leaves both polynomials hold, in a fixed order.
fn shared_signals(pool: &Pool, a: &Polynomial, b: &Polynomial) -> Vec<Leaf> {
    let signals = |p: &Polynomial| -> BTreeSet<ExprId> {
        p.atoms()
            .filter(|&x| matches!(pool.node(x), Node::Leaf(Leaf::Sensor(..) | Leaf::Input(..))))
            .collect()
    };
    let (sa, sb) = (signals(a), signals(b));
    sa.intersection(&sb)
        .filter_map(|&x| match pool.node(x) {
            Node::Leaf(l) => Some(l),
            _ => None,
        })
        .collect()
}

/// The coefficient of `leaf` in `p` when `p` holds it linearly, times parameters only.
fn coefficient(pool: &Pool, p: &Polynomial, leaf: Leaf) -> Option<Polynomial> {
    let (coefficients, _) = p.split_linear(pool, |l| (l == leaf).then_some(0))?;
    let [c] = coefficients.as_slice() else {
        return None;
    };
    let constant = c.atoms().all(|a| pool.is_constant(a));
    constant.then(|| c.clone())
}
