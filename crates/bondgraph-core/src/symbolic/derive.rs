//! d/dt of expressions, with the chain rule through every function of the language.

use super::hash::FastMap;

use super::pool::{children, ExprId, Leaf, LeafKind, Node, Pool};
use crate::expr::{BinOp, Func};

/// Time derivatives, memoised so a shared subexpression is differentiated once.
///
/// How a leaf varies is the caller's choice (`leaf`): for residuals, a measured signal's
/// derivative is a new known signal; for a simulation, a state's derivative is its state
/// equation. `leaf` returns `None` for a leaf it cannot differentiate.
pub struct Derivatives<L: LeafKind, F> {
    memo: FastMap<ExprId<L>, ExprId<L>>,
    /// With [`Self::exact`]: for each node differentiated, the arguments `x` of the `sign(x)`
    /// whose jumps its derivative leaves out (an impulse `2 δ(x) x'` times what multiplies
    /// the sign there, unless that vanishes where `x` does). Empty lists are not kept.
    jumps: FastMap<ExprId<L>, Vec<ExprId<L>>>,
    leaf: F,
    /// With respect to time, `d/dt int(a) = a`; for a partial derivative with respect to a
    /// leaf, `∂ int(a) = int(∂a)`.
    partial: bool,
    /// Whether a time derivative through `sign()` of a moving argument is refused rather
    /// than taken as 0 (see [`Self::exact`]).
    exact: bool,
    /// Whether one was refused (see [`Self::take_non_smooth`]).
    non_smooth: bool,
}

impl<L: LeafKind, F: FnMut(&mut Pool<L>, L) -> Option<ExprId<L>>> Derivatives<L, F> {
    /// Derivatives with the given rule for leaves.
    pub fn new(leaf: F) -> Self {
        Derivatives {
            memo: FastMap::default(),
            jumps: FastMap::default(),
            leaf,
            partial: false,
            exact: false,
            non_smooth: false,
        }
    }

    /// The same rule, refusing (`None`) a time derivative through `sign()` of an argument
    /// that moves: it is an impulse where the argument crosses zero, not 0, and a relation
    /// differentiated through it would lose the jump (a dry friction's `2 Fc` at each
    /// reversal). Where the derivative is a slope (a Newton step's, a sensitivity) 0 is right
    /// almost everywhere, and that is the default.
    #[must_use]
    pub fn exact(mut self) -> Self {
        self.exact = true;
        self
    }

    /// Partial derivatives: `leaf` gives each leaf's (1 for the variable, 0 for the others),
    /// and an integral's is the integral of its argument's.
    pub fn partial(leaf: F) -> Self {
        Derivatives {
            memo: FastMap::default(),
            jumps: FastMap::default(),
            leaf,
            partial: true,
            exact: false,
            non_smooth: false,
        }
    }

    /// Whether a derivative was refused since the last call because it went through
    /// `sign()` of a moving argument (directly, or through `abs`, `min` or `max` past their
    /// first derivative); the flag is cleared.
    pub fn take_non_smooth(&mut self) -> bool {
        std::mem::take(&mut self.non_smooth)
    }

    /// d/dt of a leaf under the rule.
    pub fn of_leaf(&mut self, pool: &mut Pool<L>, leaf: L) -> Option<ExprId<L>> {
        (self.leaf)(pool, leaf)
    }

    /// d/dt of `root`, or `None` if a leaf has no derivative under the rule, or, [`Self::exact`],
    /// if it would go through `sign()` of an argument that moves (then
    /// [`Self::take_non_smooth`] says so).
    pub fn of(&mut self, pool: &mut Pool<L>, root: ExprId<L>) -> Option<ExprId<L>> {
        let (d, jumps) = self.with_jumps(pool, root)?;
        if !jumps.is_empty() {
            self.refuse();
            return None;
        }
        Some(d)
    }

    /// Records a derivative refused for the jumps of a `sign()` (see [`Self::take_non_smooth`]).
    pub fn refuse(&mut self) {
        self.non_smooth = true;
    }

    /// d/dt of `root` as [`Self::of`], with the arguments of the `sign()`s whose jumps it
    /// leaves out instead of a refusal (empty unless [`Self::exact`]): for a caller that
    /// knows what multiplies `root` (a polynomial's other factors), which may vanish there.
    pub fn with_jumps(
        &mut self,
        pool: &mut Pool<L>,
        root: ExprId<L>,
    ) -> Option<(ExprId<L>, Vec<ExprId<L>>)> {
        // Only nodes not yet differentiated are visited.
        for id in pool.reachable_unless(root, |id| self.memo.contains_key(&id)) {
            let d = self.node(pool, id)?;
            self.memo.insert(id, d);
            if self.exact {
                let jumps = self.jumps_of(pool, id);
                if !jumps.is_empty() {
                    self.jumps.insert(id, jumps);
                }
            }
        }
        let d = self.memo.get(&root).copied()?;
        Some((d, self.jumps.get(&root).cloned().unwrap_or_default()))
    }

    /// The `sign()` arguments whose jumps the derivative of `id` leaves out, from its
    /// children's (already differentiated): a `sign(x)` of a moving `x` adds `x`; a product
    /// drops a factor's `x` where the other factor vanishes at `x = 0` (`sign(x)·√|x|`, an
    /// orifice's law, is continuous there, and its derivative holds no impulse).
    fn jumps_of(&self, p: &Pool<L>, id: ExprId<L>) -> Vec<ExprId<L>> {
        let of = |x: ExprId<L>| self.jumps.get(&x).cloned().unwrap_or_default();
        let mut out = match p.node(id) {
            Node::Num(_) | Node::Leaf(_) | Node::Int(_) => Vec::new(),
            Node::Call1(Func::Sign, a) => {
                let moving = self
                    .memo
                    .get(&a)
                    .is_some_and(|&da| p.as_num(da) != Some(0.0));
                let mut j = of(a);
                if moving {
                    j.push(a);
                }
                j
            }
            Node::Binary(BinOp::Mul, a, b) => {
                let mut j: Vec<_> = (of(a).into_iter())
                    .filter(|&x| !vanishes(p, b, x))
                    .collect();
                j.extend(of(b).into_iter().filter(|&x| !vanishes(p, a, x)));
                j
            }
            Node::Binary(BinOp::Pow, a, b) => {
                // c a^(c-1) a': with c > 1 the factor vanishes where a does.
                let steep = p.as_num(b).is_some_and(|c| c > 1.0);
                let mut j: Vec<_> = (of(a).into_iter())
                    .filter(|&x| !(steep && vanishes(p, a, x)))
                    .collect();
                j.extend(of(b));
                j
            }
            node => children(node).flat_map(of).collect(),
        };
        out.sort_unstable();
        out.dedup();
        out
    }

    fn node(&mut self, p: &mut Pool<L>, id: ExprId<L>) -> Option<ExprId<L>> {
        let d = |s: &Self, x: ExprId<L>| s.memo.get(&x).copied();
        Some(match p.node(id) {
            Node::Num(_) => p.num(0.0),
            Node::Leaf(l) => (self.leaf)(p, l)?,
            Node::Neg(a) => {
                let da = d(self, a)?;
                p.neg(da)
            }
            Node::Binary(op, a, b) => {
                let (da, db) = (d(self, a)?, d(self, b)?);
                binary(p, op, a, b, da, db)
            }
            Node::Call1(f, a) => {
                let da = d(self, a)?;
                let outer = outer_derivative(p, f, a, id);
                p.mul(outer, da)
            }
            Node::Call2(f, a, b) => {
                // min(a, b) = (a + b)/2 - |a - b|/2, max the same with +.
                let (da, db) = (d(self, a)?, d(self, b)?);
                let half = p.num(0.5);
                let sum = p.add(da, db);
                let mean = p.mul(half, sum);
                let gap = p.sub(a, b);
                let s = p.call(Func::Sign, &[gap]);
                let dgap = p.sub(da, db);
                let sd = p.mul(s, dgap);
                let hs = p.mul(half, sd);
                if f == Func::Max {
                    p.add(mean, hs)
                } else {
                    p.sub(mean, hs)
                }
            }
            Node::Int(a) if self.partial => {
                let da = d(self, a)?;
                p.int(da)
            }
            Node::Int(a) => a,
        })
    }
}

/// Whether `v` is 0 wherever `x` is: `x` itself, or a factor, power, `abs`, `sqrt` or
/// `sign` of it (structurally: the pool shares equal subexpressions).
pub(crate) fn vanishes<L: LeafKind>(p: &Pool<L>, v: ExprId<L>, x: ExprId<L>) -> bool {
    if v == x {
        return true;
    }
    match p.node(v) {
        Node::Neg(u) | Node::Call1(Func::Abs | Func::Sqrt | Func::Sign, u) => vanishes(p, u, x),
        Node::Binary(BinOp::Mul, a, b) => vanishes(p, a, x) || vanishes(p, b, x),
        Node::Binary(BinOp::Div, a, _) => vanishes(p, a, x),
        Node::Binary(BinOp::Pow, a, c) => p.as_num(c).is_some_and(|c| c > 0.0) && vanishes(p, a, x),
        _ => false,
    }
}

fn binary<L: LeafKind>(
    p: &mut Pool<L>,
    op: BinOp,
    a: ExprId<L>,
    b: ExprId<L>,
    da: ExprId<L>,
    db: ExprId<L>,
) -> ExprId<L> {
    let zero = |p: &Pool<L>, x: ExprId<L>| p.as_num(x) == Some(0.0);
    match op {
        BinOp::Add => p.add(da, db),
        BinOp::Sub => p.sub(da, db),
        BinOp::Mul => {
            let l = p.mul(da, b);
            let r = p.mul(a, db);
            p.add(l, r)
        }
        BinOp::Div if zero(p, db) => p.div(da, b),
        BinOp::Div => {
            let l = p.div(da, b);
            let num = p.mul(a, db);
            let two = p.num(2.0);
            let b2 = p.pow(b, two);
            let r = p.div(num, b2);
            p.sub(l, r)
        }
        BinOp::Pow if zero(p, db) => {
            let one = p.num(1.0);
            let bm1 = p.sub(b, one);
            let pw = p.pow(a, bm1);
            let k = p.mul(b, pw);
            p.mul(k, da)
        }
        BinOp::Pow => {
            // d(a^b) = a^b (b' ln a + b a' / a)
            let ab = p.pow(a, b);
            let ln = p.call(Func::Log, &[a]);
            let t1 = p.mul(db, ln);
            let ba = p.mul(b, da);
            let t2 = p.div(ba, a);
            let s = p.add(t1, t2);
            p.mul(ab, s)
        }
    }
}

/// f'(a) for a function of one argument; `fa` is the node f(a) itself.
fn outer_derivative<L: LeafKind>(
    p: &mut Pool<L>,
    f: Func,
    a: ExprId<L>,
    fa: ExprId<L>,
) -> ExprId<L> {
    let one = p.num(1.0);
    let two = p.num(2.0);
    match f {
        Func::Exp => fa,
        Func::Log => p.div(one, a),
        Func::Sqrt => {
            let d = p.mul(two, fa);
            p.div(one, d)
        }
        Func::Abs => p.call(Func::Sign, &[a]),
        Func::Sign => p.num(0.0),
        Func::Sin => p.call(Func::Cos, &[a]),
        Func::Cos => {
            let s = p.call(Func::Sin, &[a]);
            p.neg(s)
        }
        Func::Tan => {
            let c = p.call(Func::Cos, &[a]);
            let c2 = p.pow(c, two);
            p.div(one, c2)
        }
        Func::Tanh => {
            let t2 = p.pow(fa, two);
            p.sub(one, t2)
        }
        Func::Atan => {
            let a2 = p.pow(a, two);
            let d = p.add(one, a2);
            p.div(one, d)
        }
        Func::Atanh => {
            let a2 = p.pow(a, two);
            let d = p.sub(one, a2);
            p.div(one, d)
        }
        // Two-argument functions are handled by the caller.
        Func::Min | Func::Max => p.num(f64::NAN),
    }
}

/// The usual rule for known signals: parameters are constant, the derivative of a measured or
/// input signal is its next derivative, as is a torn unknown's and an auxiliary signal's;
/// dt/dt = 1. States and
/// unknowns have no rule.
pub(crate) fn known_signal_rule(p: &mut Pool, leaf: Leaf) -> Option<ExprId> {
    match leaf {
        Leaf::Param(_) => Some(p.num(0.0)),
        Leaf::Input(u, n) => Some(p.leaf(Leaf::Input(u, n + 1))),
        Leaf::Sensor(s, n) => Some(p.leaf(Leaf::Sensor(s, n + 1))),
        Leaf::Tear(v, n) => Some(p.leaf(Leaf::Tear(v, n + 1))),
        Leaf::Aux(k, n) => Some(p.leaf(Leaf::Aux(k, n + 1))),
        Leaf::Root(k, n) => Some(p.leaf(Leaf::Root(k, n + 1))),
        Leaf::Time => Some(p.num(1.0)),
        Leaf::State(_) | Leaf::Var(_) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::super::Evaluator;
    use super::*;
    use crate::graph::InputId;

    /// d/dt of f(u(t)) against a central difference, with u(t) = sin(t) known exactly.
    #[test]
    fn chain_rule_matches_finite_differences() {
        let mut p = Pool::default();
        let u = p.leaf(Leaf::Input(InputId(0), 0));
        let t = p.leaf(Leaf::Time);
        let two = p.num(2.0);
        let half = p.num(0.5);
        let mut exprs = Vec::new();
        for f in Func::ALL {
            // u + 2 keeps log and sqrt in their domain, u/2 keeps atanh in its.
            let arg = if f == Func::Atanh {
                p.mul(u, half)
            } else {
                p.add(u, two)
            };
            let e = if f.arity() == 2 {
                p.call(f, &[arg, half])
            } else {
                p.call(f, &[arg])
            };
            exprs.push(e);
        }
        let ut = p.mul(u, t);
        let q = p.div(ut, two);
        exprs.push(p.pow(q, two));
        exprs.push(p.pow(two, ut));
        let iu = p.int(u);
        exprs.push(iu);
        let value = |p: &Pool, e: ExprId, time: f64| {
            Evaluator::new(p, &|leaf| match leaf {
                Leaf::Input(_, 0) => time.sin(),
                Leaf::Input(_, 1) => time.cos(),
                Leaf::Time => time,
                _ => f64::NAN,
            })
            .value(e)
        };
        for e in exprs {
            let mut rule = Derivatives::new(known_signal_rule);
            let d = rule.of(&mut p, e).expect("differentiable");
            for time in [0.3, 1.1, 2.0] {
                let exact = value(&p, d, time);
                let h = 1e-5;
                let numeric = if matches!(p.node(e), Node::Int(_)) {
                    time.sin()
                } else {
                    (value(&p, e, time + h) - value(&p, e, time - h)) / (2.0 * h)
                };
                assert!(
                    (exact - numeric).abs() < 1e-5 * (1.0 + exact.abs()),
                    "{e:?} at {time}: {exact} vs {numeric}"
                );
            }
        }
    }

    /// Exact time derivatives refuse `sign()` of a moving signal (a dry friction's law: its
    /// derivative is an impulse at each reversal), and its products with what vanishes
    /// there pass (an orifice's `sign(x)·√|x|` is continuous): `abs` once, not twice.
    #[test]
    fn exact_derivatives_refuse_the_jumps_of_sign_only() {
        let mut p = Pool::default();
        let x = p.leaf(Leaf::Input(InputId(0), 0));
        let fc = p.num(1.5);
        let s = p.call(Func::Sign, &[x]);
        let friction = p.mul(fc, s);
        let a = p.call(Func::Abs, &[x]);
        let root = p.call(Func::Sqrt, &[a]);
        let orifice = p.mul(s, root);
        let cube = {
            let third = p.num(1.0 / 3.0);
            let r = p.pow(a, third);
            p.mul(s, r)
        };
        let t = p.leaf(Leaf::Time);
        let still = p.call(Func::Sign, &[t]);
        let constant = p.sub(t, t);
        let frozen = p.call(Func::Sign, &[constant]);
        let mut exact = Derivatives::new(known_signal_rule).exact();
        assert!(exact.of(&mut p, friction).is_none());
        assert!(exact.take_non_smooth());
        assert!(!exact.take_non_smooth(), "the flag is cleared once read");
        assert!(exact.of(&mut p, orifice).is_some());
        assert!(exact.of(&mut p, cube).is_some());
        assert!(exact.of(&mut p, frozen).is_some());
        assert!(exact.of(&mut p, still).is_none(), "sign(t) jumps at t = 0");
        let slope = exact.of(&mut p, a).expect("|x|' = sign(x) x'");
        assert!(exact.of(&mut p, slope).is_none(), "|x|'' holds the impulse");
        let mut loose = Derivatives::new(known_signal_rule);
        assert!(
            loose.of(&mut p, friction).is_some(),
            "a slope: 0 almost everywhere"
        );
        assert!(!loose.take_non_smooth());
    }
}
