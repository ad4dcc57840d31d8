// `residuals = best`: the DC motor's residuals beyond one per detector, in the generated code.
#![deny(warnings)]

bondgraph::bond_graph!("../../models/dc_motor.bg", residuals = best);

fn main() {
    // Four residuals for two detectors: every fault class the structure allows.
    assert_eq!(dc_motor::RESIDUAL_COUNT, 4);
    // A current sensor fault leaves the residual derived without the current quiet.
    assert_eq!(dc_motor::candidates(&[true, true, false, true]), ["i"]);
}
