// A model realised as written: the residuals read the derivatives the relations hold.
#![deny(warnings)]

bondgraph::bond_graph!("../../models/dc_motor.bg", realise = direct);

fn main() {
    assert_eq!(dc_motor::INTEGRATED, [false, false]);
    assert_eq!(dc_motor::RAW_ORDERS, [0, 1, 1]);
    let p = dc_motor::Params::default();
    // At rest with the current that holds the motor's friction: U0 = Re i + ke y1.
    let s = dc_motor::Signals {
        U0: 0.3 * 0.2 + 0.5 * 1.0,
        i: 0.2,
        i_d1: 0.0,
        y1: 1.0,
        y1_d1: 0.0,
    };
    let r = dc_motor::residuals(&p, &s);
    assert!(r[0].abs() < 1e-15, "{r:?}");
    assert!((r[1] - (0.5 * 0.2 - 0.1 * 1.0)).abs() < 1e-15, "{r:?}");
}
