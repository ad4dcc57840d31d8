//! Every model in `models/`: it checks, its DOT is stable, snapshotted, and renders with Graphviz.

mod common;

use std::io::Write as _;
use std::process::{Command, Stdio};

use common::{bgc, code, relative, stderr, stdout};

#[test]
fn every_model_checks_and_emits_dot() {
    insta::glob!("../models", "*.bg", |path| {
        let model = relative(path);
        let check = bgc(&["check", &model]);
        assert_eq!(code(&check), 0, "{model}: {}", stderr(&check));
        assert!(
            stderr(&check).is_empty(),
            "{model} warns:\n{}",
            stderr(&check)
        );
        insta::assert_snapshot!("check", stdout(&check));

        let dot = bgc(&[&model, "--emit", "dot"]);
        assert_eq!(code(&dot), 0, "{model}: {}", stderr(&dot));
        let again = bgc(&[&model, "--emit", "dot"]);
        assert_eq!(
            dot.stdout, again.stdout,
            "{model}: DOT differs between runs"
        );
        insta::assert_snapshot!("dot", stdout(&dot));
        render(&model, &dot.stdout);
    });
}

/// Renders DOT with Graphviz. Where `dot` is missing the test is skipped with a note, except
/// under CI (`CI` set), whose script installs Graphviz: there a missing `dot` is a failure.
fn render(model: &str, dot: &[u8]) {
    let child = Command::new("dot")
        .arg("-Tsvg")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(child) => child,
        Err(e) if std::env::var_os("CI").is_none() => {
            eprintln!("note: Graphviz `dot` not found ({e}); DOT rendering not checked");
            return;
        }
        Err(e) => panic!("Graphviz `dot` is needed under CI: {e}"),
    };
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(dot)
        .expect("write DOT");
    let out = child.wait_with_output().expect("dot runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{model}: dot -Tsvg failed: {err}");
    assert!(err.trim().is_empty(), "{model}: dot -Tsvg warned: {err}");
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("<svg"),
        "{model}: no SVG"
    );
}
