//! `bond_graph!` errors as a user meets them: every error of a model is a compile error
//! naming the file, line and column with the offending line and what was expected (inline:
//! at the offending token), with the help `bgc check` gives (trybuild compares the messages
//! with the `.stderr` files next to the cases). Models that compile are in the `bondgraph`
//! crate's `tests/macro_models.rs`, built with the rest of the workspace: trybuild builds its
//! cases in a crate of its own, with every dependency built again, and only compile errors
//! need that.

#[test]
fn bond_graph_reports_every_error_where_it_is() {
    // trybuild builds the cases in a crate of its own: model paths stay relative to this one.
    std::env::set_var("BOND_GRAPH_ROOT", env!("CARGO_MANIFEST_DIR"));
    // Checking needs no debug information, and the cases' crate builds every dependency.
    std::env::set_var("CARGO_PROFILE_DEV_DEBUG", "0");
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/fail/*.rs");
}
