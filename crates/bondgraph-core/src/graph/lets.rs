//! `let` definitions: an order in which each follows those it uses, and cycles reported.

use super::laws::Variability;
use super::model::{LetId, Signal, SignalExpr};
use crate::diagnostic::{Code, Diagnostic, Diagnostics};
use crate::syntax::ast::LetDecl;

/// The `let`s in dependency order; those on a cycle (reported here) or depending on one are
/// left out. Iterative depth-first search, so a long chain of `let`s cannot overflow the stack.
pub(crate) fn order(
    decls: &[&LetDecl],
    resolved: &[Option<SignalExpr>],
    diagnostics: &mut Diagnostics,
) -> Vec<LetId> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
        Broken,
    }
    let deps: Vec<Vec<u32>> = resolved.iter().map(|e| dependencies(e.as_ref())).collect();
    let mut mark = vec![Mark::New; decls.len()];
    let mut order = Vec::with_capacity(decls.len());
    for root in 0..decls.len() {
        if mark[root] != Mark::New {
            continue;
        }
        // Stack of (let, index of the next dependency to visit).
        let mut stack = vec![(root, 0usize)];
        mark[root] = Mark::Open;
        while let Some(&mut (node, ref mut next)) = stack.last_mut() {
            if let Some(&dep) = deps[node].get(*next) {
                *next += 1;
                let dep = dep as usize;
                match mark[dep] {
                    Mark::New => {
                        mark[dep] = Mark::Open;
                        stack.push((dep, 0));
                    }
                    Mark::Open => {
                        let start = stack.iter().position(|&(n, _)| n == dep).unwrap_or(0);
                        let cycle: Vec<usize> = stack[start..].iter().map(|&(n, _)| n).collect();
                        diagnostics.push(cycle_error(decls, &cycle));
                        cycle.iter().for_each(|&n| mark[n] = Mark::Broken);
                    }
                    Mark::Broken => mark[node] = Mark::Broken,
                    Mark::Done => {}
                }
            } else {
                stack.pop();
                if mark[node] == Mark::Open {
                    mark[node] = Mark::Done;
                    order.push(LetId(node as u32));
                } else if let Some(&(parent, _)) = stack.last() {
                    // A let that uses a broken one is broken too, but not reported again.
                    mark[parent] = Mark::Broken;
                }
            }
        }
    }
    order
}

fn dependencies(expr: Option<&SignalExpr>) -> Vec<u32> {
    let mut deps = Vec::new();
    if let Some(expr) = expr {
        expr.for_each_leaf(&mut |s| {
            if let Signal::Let(LetId(i)) = s {
                deps.push(*i);
            }
        });
    }
    deps.sort_unstable();
    deps.dedup();
    deps
}

fn cycle_error(decls: &[&LetDecl], cycle: &[usize]) -> Diagnostic {
    let first = decls[cycle[0]];
    let names: Vec<&str> = cycle
        .iter()
        .chain(std::iter::once(&cycle[0]))
        .map(|&n| decls[n].name.name.as_str())
        .collect();
    let mut d = Diagnostic::error(
        Code::Cycle,
        first.name.span,
        format!("`let` definitions form a cycle: {}", names.join(" -> ")),
    )
    .with_label("this definition depends on itself")
    .with_help("a `let` may use only `let`s that do not use it back");
    for &n in &cycle[1..] {
        d = d.with_note(
            decls[n].name.span,
            format!("`{}` is on the cycle", decls[n].name.name),
        );
    }
    d
}

/// How a resolved `let` varies, given those of the `let`s before it; `None` if one is broken.
pub(crate) fn variability(expr: &SignalExpr, lets: &[Option<Variability>]) -> Option<Variability> {
    let mut most = Some(Variability::Constant);
    expr.for_each_leaf(&mut |s| {
        let v = match s {
            Signal::Param(_) => Some(Variability::Constant),
            Signal::Input(_) | Signal::Time => Some(Variability::Known),
            Signal::Sensor(_) => Some(Variability::Measured),
            Signal::Let(l) => lets.get(l.index()).copied().flatten(),
            Signal::Port(_) => None,
        };
        most = most.zip(v).map(|(a, b)| a.max(b));
    });
    most
}

/// Most nodes a `let`'s definition may have once every `let` it uses is written out. Past it,
/// the expressions bgc prints (which are trees) would be too large to read or to write:
/// `let l_i = l_{i-1} * l_{i-1} + a`, 20 deep, is 3 million nodes.
pub(crate) const MAX_EXPANDED: u64 = 200_000;

/// The first `let` (in dependency order) whose written-out size passes [`MAX_EXPANDED`],
/// with that size (saturated at `u64::MAX`).
pub(crate) fn first_too_large(model: &super::BondGraph) -> Option<(LetId, u64)> {
    let mut size = vec![0u64; model.lets.len()];
    for &l in &model.let_order {
        let expr = &model.lets[l.index()].value;
        let mut leaves = 0u64;
        expr.for_each_leaf(&mut |s| {
            let n = match s {
                Signal::Let(k) => size.get(k.index()).copied().unwrap_or(1),
                _ => 1,
            };
            leaves = leaves.saturating_add(n);
        });
        let inner = nodes(expr);
        size[l.index()] = leaves.saturating_add(inner);
        if size[l.index()] > MAX_EXPANDED {
            return Some((l, size[l.index()]));
        }
    }
    None
}

/// The operator nodes of an expression (its leaves not counted). Recursion is bounded by the
/// parser's limits on nesting.
fn nodes(expr: &SignalExpr) -> u64 {
    use crate::expr::Expr;
    match expr {
        Expr::Num(_) => 1,
        Expr::Leaf(_) => 0,
        Expr::Neg(a) | Expr::Der(a, _) | Expr::Int(a) => 1 + nodes(a),
        Expr::Binary(_, a, b) => 1 + nodes(a) + nodes(b),
        Expr::Call(_, args) => 1 + args.iter().map(nodes).sum::<u64>(),
    }
}
