//! Which nodes of the residual program a backend binds to a name before the code that reads
//! them: every node read more than once (computed once), and each auxiliary signal the code
//! reads (bound under its own name). Chosen once here, so that the Rust and the C printers
//! share the same parts.

use std::collections::HashMap;

use bondgraph_core::children;
use bondgraph_core::program::{Code, Leaf};
use bondgraph_core::{Node, Pool};

/// What a bound node is called.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Binding<'a> {
    /// An auxiliary signal, under its name in the model.
    Named(&'a str),
    /// A shared part, the `k`-th (from 1) of this piece of code.
    Numbered(usize),
}

/// The nodes of `roots` to bind, children first: those read more than once (numbers and
/// leaves aside), and those of `named` that the roots read (an unread one would be dead
/// code). Linear in the nodes reached.
pub(crate) fn bindings<'a>(
    code: &Pool<Leaf>,
    roots: &[Code],
    named: &'a [(Code, String)],
) -> Vec<(Code, Binding<'a>)> {
    let names: HashMap<Code, &'a str> = named.iter().map(|(e, n)| (*e, n.as_str())).collect();
    let (order, uses) = uses(code, roots);
    let mut next = 0usize;
    let mut out = Vec::new();
    for id in order {
        let binding = match names.get(&id) {
            Some(&name) => Binding::Named(name),
            None if uses.get(&id).copied().unwrap_or(0) >= 2
                && !matches!(code.node(id), Node::Num(_) | Node::Leaf(_)) =>
            {
                next += 1;
                Binding::Numbered(next)
            }
            None => continue,
        };
        out.push((id, binding));
    }
    out
}

/// How many times each node is reached from `roots` (once per parent edge, once per root),
/// children first.
fn uses(code: &Pool<Leaf>, roots: &[Code]) -> (Vec<Code>, HashMap<Code, usize>) {
    let mut order = Vec::new();
    let mut count: HashMap<Code, usize> = HashMap::new();
    code.visit_reachable(roots, |id, node| {
        order.push(id);
        for child in children(node) {
            *count.entry(child).or_default() += 1;
        }
    });
    for &r in roots {
        *count.entry(r).or_default() += 1;
    }
    (order, count)
}
