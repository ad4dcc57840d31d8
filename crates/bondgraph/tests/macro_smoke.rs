//! The bench compiled by `bond_graph!`.
#![deny(warnings)]

bondgraph::bond_graph!("../../models/backlash_bench.bg");

#[test]
fn the_bench_compiles_and_its_residuals_vanish_on_zero_signals() {
    let p = backlash_bench::Params::default();
    let s = backlash_bench::Signals::default();
    let r = backlash_bench::residuals(&p, &s);
    assert_eq!(r.len(), 2);
}
