//! The residual program's code with the parameters folded in, for evaluation.

use bondgraph_core::program::{Code, Leaf};
use bondgraph_core::{Pool, Tape};

/// `roots` of `code` in a pool of their own, with the parameters folded to `params`.
pub(crate) fn fold(code: &Pool<Leaf>, roots: &[Code], params: &[f64]) -> (Pool<Leaf>, Vec<Code>) {
    let mut pool = Pool::default();
    let roots = (roots.iter())
        .map(|&r| {
            pool.import_from(code, r, |p: &mut Pool<Leaf>, l| match l {
                Leaf::Parameter(k) => p.num(params[k.index()]),
                other => p.leaf(other),
            })
        })
        .collect();
    (pool, roots)
}

/// `roots` of `code` as one tape, with the parameters folded to `params`.
pub(crate) fn tape(code: &Pool<Leaf>, roots: &[Code], params: &[f64]) -> Tape<Leaf> {
    let (pool, roots) = fold(code, roots, params);
    Tape::new(&pool, &roots)
}
