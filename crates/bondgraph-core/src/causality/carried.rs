//! What a detector reads and a source applies once the faults they carry (`with`) are part of
//! the model: a detector reads `gain·x + bias + drift·t` of its junction's `x`, a source
//! applies `gain·value + offset`. At the healthy values (gain 1, the others 0) both are the
//! plain variable, so the relations are those of a model without the clause.

use crate::graph::{Carried, Faults};
use crate::symbolic::{ExprId, Leaf, Pool};

/// The junction's variable from what the detector reads (`measured`, differentiated
/// `integrals` times: a `Dq` reads the integral, its derivative is the junction's flow).
pub(crate) fn from_reading(
    pool: &mut Pool,
    faults: &Faults,
    measured: ExprId,
    integrals: u32,
) -> ExprId {
    let mut x = measured;
    if integrals == 0 {
        if let Some(b) = faults.get(Carried::Bias) {
            let b = pool.leaf(Leaf::Param(b));
            x = pool.sub(x, b);
        }
    }
    if let Some(d) = faults.get(Carried::Drift) {
        let d = pool.leaf(Leaf::Param(d));
        // The drift's `d·t`, differentiated as the reading is.
        let rate = if integrals == 0 {
            let t = pool.leaf(Leaf::Time);
            pool.mul(d, t)
        } else {
            d
        };
        x = pool.sub(x, rate);
    }
    if let Some(g) = faults.get(Carried::Gain) {
        let g = pool.leaf(Leaf::Param(g));
        x = pool.div(x, g);
    }
    x
}

/// What the detector reads of its junction's variable (or of its integral, for a `Dq`/`Dp`).
pub(crate) fn reading(pool: &mut Pool, faults: &Faults, value: ExprId) -> ExprId {
    let mut y = value;
    if let Some(g) = faults.get(Carried::Gain) {
        let g = pool.leaf(Leaf::Param(g));
        y = pool.mul(g, y);
    }
    if let Some(b) = faults.get(Carried::Bias) {
        let b = pool.leaf(Leaf::Param(b));
        y = pool.add(y, b);
    }
    if let Some(d) = faults.get(Carried::Drift) {
        let d = pool.leaf(Leaf::Param(d));
        let t = pool.leaf(Leaf::Time);
        let dt = pool.mul(d, t);
        y = pool.add(y, dt);
    }
    y
}

/// What a source applies of its `value`.
pub(crate) fn applied(pool: &mut Pool, faults: &Faults, value: ExprId) -> ExprId {
    let mut y = value;
    if let Some(g) = faults.get(Carried::Gain) {
        let g = pool.leaf(Leaf::Param(g));
        y = pool.mul(g, y);
    }
    if let Some(o) = faults.get(Carried::Offset) {
        let o = pool.leaf(Leaf::Param(o));
        y = pool.add(y, o);
    }
    y
}
