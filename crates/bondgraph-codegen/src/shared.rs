//! Subexpressions an output repeats, written once under a name (`$1 = exp(...)`), so that a
//! residual reading the same long part fifteen times is read once.

use std::collections::HashMap;

use bondgraph_core::{children, Compiled, Expr, ExprId, Node, Pool, Printer, Symbol};

use crate::names;

/// A leaf of an expression with its shared parts named: a name of the model, or a part.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Part {
    Symbol(Symbol),
    Shared(usize),
}

/// Expressions of the product rebuilt with their shared parts named.
pub(crate) struct Shared<'c> {
    c: &'c Compiled,
    pool: Pool<Part>,
    /// Each named part's definition, numbered from 1, inner parts first.
    definitions: Vec<ExprId<Part>>,
    rebuilt: HashMap<Expr, ExprId<Part>>,
}

impl<'c> Shared<'c> {
    /// Names the parts that more than one place of `counted` reads (two parents, or a
    /// parent and a root) and that take at least `shortest` characters written with the
    /// names of the parts inside them; `also` are written with those names too, but what
    /// they repeat is not named for them (a residual's realisation repeats its relation).
    pub(crate) fn new(
        c: &'c Compiled,
        counted: &[Expr],
        also: &[Expr],
        shortest: usize,
    ) -> Shared<'c> {
        let (_, uses) = post_order(c, counted);
        let all: Vec<Expr> = counted.iter().chain(also).copied().collect();
        let (order, _) = post_order(c, &all);
        let mut s = Shared {
            c,
            pool: Pool::default(),
            definitions: Vec::new(),
            rebuilt: HashMap::new(),
        };
        for e in order {
            let node = c.exprs.node(e);
            let rebuilt = s.rebuild(node);
            let named = uses.get(&e).copied().unwrap_or(0) >= 2
                && !matches!(node, Node::Leaf(_) | Node::Num(_))
                && s.text(rebuilt).chars().count() >= shortest;
            let value = if named {
                s.definitions.push(rebuilt);
                s.pool.leaf(Part::Shared(s.definitions.len()))
            } else {
                rebuilt
            };
            s.rebuilt.insert(e, value);
        }
        s
    }

    /// `node` in the rebuilt pool, its children already rebuilt.
    fn rebuild(&mut self, node: Node<Symbol>) -> ExprId<Part> {
        let r = |x: Expr| self.rebuilt[&x];
        match node {
            Node::Num(bits) => self.pool.num(f64::from_bits(bits)),
            Node::Leaf(s) => self.pool.leaf(Part::Symbol(s)),
            Node::Neg(a) => {
                let a = r(a);
                self.pool.neg(a)
            }
            Node::Binary(op, a, b) => {
                let (a, b) = (r(a), r(b));
                self.pool.binary(op, a, b)
            }
            Node::Call1(f, a) => {
                let a = r(a);
                self.pool.call(f, &[a])
            }
            Node::Call2(f, a, b) => {
                let (a, b) = (r(a), r(b));
                self.pool.call(f, &[a, b])
            }
            Node::Int(a) => {
                let a = r(a);
                self.pool.int(a)
            }
        }
    }

    fn text(&self, e: ExprId<Part>) -> String {
        let c = self.c;
        Printer::new(&self.pool, |p| match p {
            Part::Symbol(s) => names::text(c, s),
            Part::Shared(k) => format!("${k}"),
        })
        .text(e)
    }

    /// `root` (one of those given to [`Shared::new`]) as text, its shared parts by name.
    pub(crate) fn write(&self, root: Expr) -> String {
        self.text(self.rebuilt[&root])
    }

    /// The named parts as `$k = ...`, in order.
    pub(crate) fn definitions(&self) -> Vec<String> {
        (self.definitions.iter().enumerate())
            .map(|(k, &d)| format!("${} = {}", k + 1, self.text(d)))
            .collect()
    }
}

/// The nodes reached from `roots`, children before parents, and how many places read each:
/// its parents (each once) and the roots that are it.
fn post_order(c: &Compiled, roots: &[Expr]) -> (Vec<Expr>, HashMap<Expr, usize>) {
    let mut uses: HashMap<Expr, usize> = HashMap::new();
    let mut order = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for &root in roots {
        *uses.entry(root).or_default() += 1;
        // An explicit stack: the expressions of a long chain are deep.
        let mut stack = vec![(root, false)];
        while let Some((e, expanded)) = stack.pop() {
            if expanded {
                order.push(e);
                continue;
            }
            if !seen.insert(e) {
                continue;
            }
            stack.push((e, true));
            for child in children(c.exprs.node(e)) {
                *uses.entry(child).or_default() += 1;
                stack.push((child, false));
            }
        }
    }
    (order, uses)
}
