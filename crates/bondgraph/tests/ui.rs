//! `bond_graph!` as a user meets it: models that compile, and models whose errors are
//! compile errors naming the file, line and column (trybuild compares the messages with the
//! `.stderr` files next to the cases).

#[test]
fn bond_graph_compiles_models_and_reports_bad_ones_where_they_are() {
    // trybuild builds the cases in a crate of its own: model paths stay relative to this one.
    std::env::set_var("BOND_GRAPH_ROOT", env!("CARGO_MANIFEST_DIR"));
    let t = trybuild::TestCases::new();
    t.pass("tests/ui/pass/*.rs");
    t.compile_fail("tests/ui/fail/*.rs");
}
