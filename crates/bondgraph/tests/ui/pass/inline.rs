// A model written inline, with comments, units and descriptions.
#![deny(warnings)]

bondgraph::bond_graph! {
    # An RC circuit driven by a current source.
    model rc
    param R1 = 2 [Ohm] "resistance"
    param C1 = 0.5 [F]
    input I0 [A]
    Sf src = I0
    R res = R1
    C cap = C1
    De v on n "capacitor voltage"
    src -> 0:n -> res, cap
}

fn main() {
    // Realised by integration: the running value -C1 v + int(I0) - int(v)/R1.
    assert_eq!(rc::INTEGRATED, [true]);
    let p = rc::Params { R1: 4.0, ..rc::Params::default() };
    let s = rc::Signals { I0_int: 3.0, v: 4.0, v_int: 4.0 };
    assert_eq!(rc::residuals(&p, &s), [0.0]);
}
