// A model from a file, relative to the crate's manifest directory.
#![deny(warnings)]

bondgraph::bond_graph!("../../models/rlc_series.bg");

fn main() {
    let p = rlc_series::Params::default();
    let s = rlc_series::Signals::from_array([0.0; rlc_series::Signals::NAMES.len()]);
    let r: [f64; rlc_series::RESIDUAL_COUNT] = rlc_series::residuals(&p, &s);
    assert!(r.iter().all(|x| *x == 0.0));
    assert!(rlc_series::candidates(&[false, false]).is_empty());
    assert!(rlc_series::suspects(&[false, false]).is_empty());
}
