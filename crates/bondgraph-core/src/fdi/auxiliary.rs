//! Auxiliary signals: what keeps an ARR between two stretches of unmeasured storage small.
//!
//! Eliminating the unknowns between two detectors applies the operator of one stretch, a
//! polynomial `t(D)` of high degree with parameter coefficients, to what the other stretch
//! left, `r`. Multiplied out, every coefficient of `t` multiplies every term of every
//! derivative of `r`: with parameters of their own per stage, two stretches of four masses
//! give 10⁵–10⁶ terms. Named instead, `z = r` and `t(D) r = Σₖ tₖ z⁽ᵏ⁾`, the relation costs
//! the sum of the two sizes, not their product. An auxiliary signal is such a `z`: a
//! combination of known signals (and of earlier auxiliary signals), exact, and as
//! measurable as what it combines.
//!
//! What is derived from an ARR (which parameters it depends on, which signals it reads, its
//! values along trajectories) reads it with its auxiliary signals put back, as a DAG
//! ([`expand`]): shared, so linear in size, where printing it whole would not be.

use crate::index::Idx as _;
use crate::symbolic::hash::FastMap;
use crate::symbolic::{known_signal_rule, AuxIx, Derivatives, ExprId, Leaf, Pool, Simplifier};

/// A named combination of known signals.
#[derive(Clone, Debug)]
pub(crate) struct Auxiliary {
    /// Its time derivatives, in canonical form: `derivatives[n]` is the n-th (the 0-th is its
    /// definition), as far as an ARR or a later auxiliary signal reads them.
    pub derivatives: Vec<ExprId>,
}

impl Auxiliary {
    /// A new auxiliary signal defined as `definition`.
    pub(crate) fn new(definition: ExprId) -> Auxiliary {
        Auxiliary {
            derivatives: vec![definition],
        }
    }
}

/// The highest derivative of each auxiliary signal that `roots` read directly.
fn orders_read(pool: &Pool, roots: &[ExprId], top: &mut [Option<u32>]) {
    for &root in roots {
        for leaf in pool.leaves(root) {
            if let Leaf::Aux(k, n) = leaf {
                if let Some(t) = top.get_mut(k.index()) {
                    *t = Some(t.map_or(n, |t| t.max(n)));
                }
            }
        }
    }
}

/// Gives every auxiliary signal the derivatives that `roots`, or later auxiliary signals'
/// derivatives, read. `None` if one cannot be differentiated (it holds no unknown, so this
/// is not expected).
pub(crate) fn differentiate(
    pool: &mut Pool,
    auxiliaries: &mut [Auxiliary],
    roots: &[ExprId],
) -> Option<()> {
    let mut top = vec![None; auxiliaries.len()];
    orders_read(pool, roots, &mut top);
    let mut simplifier = Simplifier::default();
    let mut rule = Derivatives::new(known_signal_rule).exact();
    // A signal's derivatives read only earlier ones: the last first, then what it read.
    for k in (0..auxiliaries.len()).rev() {
        let Some(n) = top[k] else { continue };
        let aux = &mut auxiliaries[k];
        let mut p = simplifier.polynomial(pool, aux.derivatives[aux.derivatives.len() - 1]);
        while aux.derivatives.len() <= n as usize {
            p = simplifier.derivative(pool, &p, &mut rule)?;
            aux.derivatives.push(p.expr(pool));
        }
        orders_read(pool, &aux.derivatives, &mut top);
    }
    Some(())
}

/// `roots` with every auxiliary signal replaced by what it is defined as, in one pool, with
/// subexpressions shared: the size is that of the definitions, not of the text written out.
pub(crate) fn expand(pool: &mut Pool, auxiliaries: &[Auxiliary], roots: &[ExprId]) -> Vec<ExprId> {
    if auxiliaries.is_empty() {
        return roots.to_vec();
    }
    let mut expanded: FastMap<(AuxIx, u32), ExprId> = FastMap::default();
    let put_back = |pool: &mut Pool, expanded: &FastMap<(AuxIx, u32), ExprId>, e: ExprId| {
        pool.substitute(e, &mut |_, leaf| match leaf {
            Leaf::Aux(k, n) => expanded.get(&(k, n)).copied(),
            _ => None,
        })
    };
    // Each one's derivatives read earlier ones only: in order, each is expanded once.
    for (k, aux) in auxiliaries.iter().enumerate() {
        for (n, &d) in (0u32..).zip(&aux.derivatives) {
            let e = put_back(pool, &expanded, d);
            expanded.insert((AuxIx::new(k), n), e);
        }
    }
    roots
        .iter()
        .map(|&r| put_back(pool, &expanded, r))
        .collect()
}
