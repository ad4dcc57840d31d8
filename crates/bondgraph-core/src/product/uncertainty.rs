//! Each ARR's sensitivity to the parameters the model marks uncertain (`+- 5%`): the terms of
//! an adaptive threshold `Σ |∂r/∂θ| Δθ`, as in the linear-fractional bond graphs of the
//! reference paper's authors, but derived symbolically.

use super::{Compiled, Symbol};
use crate::symbolic::Derivatives;

/// Fills [`super::Arr::sensitivities`] of every ARR of `c`.
pub(crate) fn sensitivities(c: &mut Compiled) {
    let uncertain: Vec<_> = c
        .parameters
        .iter()
        .filter(|(_, p)| p.uncertainty.is_some_and(|u| u > 0.0))
        .map(|(h, _)| h)
        .collect();
    for k in 0..c.arrs.len() {
        let arr = &c.arrs[k];
        // An auxiliary signal carries parameters of its own that the ARR's leaves hide, and a
        // simulated residual's states depend on parameters through their whole history.
        if !arr.auxiliaries.is_empty() || arr.form == super::ResidualForm::Simulated {
            c.arrs[k].sensitivities = None;
            continue;
        }
        let roots = c.roots_read(&[arr.expr]);
        // A root's derivatives are functions of the root: written out, the root itself is
        // all that moves with θ beyond the parameters.
        let expr = {
            let roots = &c.roots;
            c.exprs.substitute(arr.expr, &mut |_, leaf| match leaf {
                Symbol::Root(h, n) if n > 0 => roots[h].derivative(n),
                _ => None,
            })
        };
        let mut leaves = c.exprs.leaves(expr);
        for &h in &roots {
            leaves.extend(c.exprs.leaves(c.roots[h].residual));
        }
        let mut out = Vec::new();
        for &theta in &uncertain {
            if !leaves.contains(&Symbol::Parameter(theta)) {
                continue;
            }
            if let Some(s) = sensitivity(c, expr, &roots, theta) {
                if c.exprs.as_num(s) != Some(0.0) {
                    out.push((theta, s));
                }
            }
        }
        c.arrs[k].sensitivities = Some(out);
    }
}

/// `dr/dθ` of `expr`, through the roots it reads (`roots`, in definition order): a root of
/// `g(z, θ) = 0` moves with θ as `dz/dθ = −(∂g/∂θ)/(∂g/∂z)`, `∂g/∂θ` taken through the
/// earlier roots `g` reads.
fn sensitivity(
    c: &mut Compiled,
    expr: super::Expr,
    roots: &[super::Handle<super::Root>],
    theta: super::Handle<super::Parameter>,
) -> Option<super::Expr> {
    let mut moves: std::collections::HashMap<Symbol, super::Expr> = Default::default();
    let along = |c: &mut Compiled,
                 e: super::Expr,
                 moves: &std::collections::HashMap<Symbol, super::Expr>| {
        let mut d = Derivatives::partial(|p: &mut crate::symbolic::Pool<Symbol>, leaf| {
            Some(match moves.get(&leaf) {
                Some(&m) => m,
                None => p.num(f64::from(u8::from(leaf == Symbol::Parameter(theta)))),
            })
        });
        d.of(&mut c.exprs, e)
    };
    for &h in roots {
        let (g, slope) = (c.roots[h].residual, c.roots[h].slope);
        let held = along(c, g, &moves)?;
        let ratio = c.exprs.div(held, slope);
        let dz = c.exprs.neg(ratio);
        moves.insert(Symbol::Root(h, 0), dz);
    }
    along(c, expr, &moves)
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use crate::product::{Compiled, Expr, Signal, Symbol};
    use crate::symbolic::Node;
    use crate::{compile, Evaluator, Options};

    /// Every parameter of the bench marked `+- 10%`.
    fn bench() -> Compiled {
        let text = include_str!("../../../../models/backlash_bench.bg");
        let uncertain: String = text
            .lines()
            .map(|l| {
                if l.starts_with("param ") {
                    let l = l.replace("+- 5%", "");
                    let (decl, description) = l.split_once('"').unwrap_or((&l, ""));
                    if description.is_empty() {
                        format!("{decl} +- 10%\n")
                    } else {
                        format!("{decl} +- 10% \"{description}\n")
                    }
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        // As written: an ARR realised by integration has no adaptive threshold.
        let options = Options {
            realise: crate::Realise::Direct,
            ..Options::default()
        };
        compile(&uncertain, "bench.bg", &options)
            .expect("compiles")
            .compiled
    }

    /// `r` at signal values `x` (one per symbol, integrals by signal) and parameters `theta`.
    fn value(
        c: &Compiled,
        e: Expr,
        theta: &[f64],
        x: &HashMap<Symbol, f64>,
        ints: &HashMap<Signal, f64>,
    ) -> f64 {
        let leaf = |s: Symbol| match s {
            Symbol::Parameter(p) => theta[p.index()],
            other => x.get(&other).copied().unwrap_or(0.3),
        };
        let mut integrals = HashMap::new();
        c.exprs.visit_reachable(&[e], |id, node| {
            if let Node::Int(arg) = node {
                let terms = c.linear_terms(arg).expect("linear integrals in the bench");
                let v: f64 = terms
                    .iter()
                    .map(|&(plus, k, s)| {
                        let k = k.map_or(1.0, |k| Evaluator::new(&c.exprs, leaf).value(k));
                        (if plus { k } else { -k }) * ints[&s]
                    })
                    .sum();
                integrals.insert(id, v);
            }
        });
        Evaluator::new(&c.exprs, leaf)
            .with_integrals(integrals)
            .value(e)
    }

    /// Each sensitivity equals the residual's central difference in its parameter, at points
    /// where the signals and their integrals take arbitrary values.
    #[test]
    fn sensitivities_are_the_partial_derivatives_of_the_residuals() {
        let c = bench();
        assert!(!c.has_errors(), "{:?}", c.diagnostics);
        let theta: Vec<f64> = c.parameters.values().map(|p| p.value).collect();
        assert!(c.parameters.values().all(|p| p
            .uncertainty
            .is_some_and(|u| (u - p.value.abs() * 0.1).abs() < 1e-15)));
        let mut checked = 0;
        for seed in 0..3u32 {
            let mut x = HashMap::new();
            for arr in &c.arrs {
                for l in c.exprs.leaves(arr.expr) {
                    let k = x.len() as f64;
                    x.entry(l)
                        .or_insert(0.2 + 0.37 * ((k * 1.7 + f64::from(seed)).sin()));
                }
            }
            let ints: HashMap<Signal, f64> = c
                .sensors
                .iter()
                .map(|(h, _)| Signal::Sensor(h))
                .chain(c.inputs.iter().map(|(u, _)| Signal::Input(u)))
                .enumerate()
                .map(|(i, s)| (s, 0.1 * (i as f64 + 1.0) + 0.05 * f64::from(seed)))
                .collect();
            for arr in &c.arrs {
                let sensitivities = arr.sensitivities.as_ref().expect("derived");
                assert!(!sensitivities.is_empty());
                for &(p, s) in sensitivities {
                    let h = 1e-6 * theta[p.index()].abs().max(1.0);
                    let (mut up, mut down) = (theta.clone(), theta.clone());
                    up[p.index()] += h;
                    down[p.index()] -= h;
                    let fd = (value(&c, arr.expr, &up, &x, &ints)
                        - value(&c, arr.expr, &down, &x, &ints))
                        / (2.0 * h);
                    let exact = value(&c, s, &theta, &x, &ints);
                    assert!(
                        (fd - exact).abs() <= 1e-5 * (1.0 + exact.abs()),
                        "{} d/d{}: {exact} vs {fd}",
                        arr.name,
                        c.parameters[p].name
                    );
                    checked += 1;
                }
            }
        }
        // ARR1 reads 9 parameters, ARR2 the dead zone's and the load's.
        assert!(checked >= 3 * 12, "{checked}");
    }
}
