//! The residual code `bgc --emit rust` writes, included in a private module the way a user's
//! bench program does (`mod m { include!("m.rs"); }`), compiles without a warning even where
//! the program reads only a part of it; and the included file is what bgc writes today.

#![deny(warnings)]

mod spring {
    include!("included/hardening_spring.rs");
}

/// The program reads only the parameters: nothing else may warn as unused.
#[test]
fn included_code_compiles_without_warnings() {
    let p = spring::Params::default();
    assert!(p.k1 > 0.0);
}

/// The included file is the emitter's output for the model, so that this test checks what
/// bgc writes now (regenerate with `bgc models/hardening_spring.bg --emit rust`).
#[test]
fn the_included_file_is_what_bgc_writes() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let text =
        std::fs::read_to_string(format!("{root}/models/hardening_spring.bg")).expect("model");
    let c = bondgraph_core::compile(&text, "models/hardening_spring.bg", &Default::default())
        .expect("valid")
        .compiled;
    let written = std::fs::read_to_string(format!(
        "{}/tests/included/hardening_spring.rs",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("included file");
    assert_eq!(
        bondgraph_codegen::rust::emit(&c).expect("writable"),
        written
    );
}
