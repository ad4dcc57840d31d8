//! Every model in `models/`: it checks; every emitter's output is stable and snapshotted; the
//! JSON follows the documented schema; the DOT renders with Graphviz.

use std::io::Write as _;
use std::process::{Command, Stdio};

use crate::common::{bgc, code, relative, scratch, stderr, stdout};

/// Runs bgc twice, requires success and byte-identical output, returns it.
fn emit(model: &str, args: &[&str]) -> String {
    let mut full = vec![model];
    full.extend(args);
    let out = bgc(&full);
    assert_eq!(code(&out), 0, "{model} {args:?}: {}", stderr(&out));
    // No other warning: every expression of the models is simplified within the limits. The
    // diagnostics a model may carry on purpose say what its ARRs assume (a storage law kept
    // in integral causality in diagnosis: `hardening_spring.bg`) or what its FSM rows mean
    // (a parameter several components read, the tanks' `rho` and `g`).
    let err = stderr(&out);
    let unexpected = err.lines().any(|l| {
        let l = l.trim_start();
        (l.starts_with("bg::") && l != "bg::mixed-causality" && l != "bg::shared-parameter")
            || l.starts_with("bgc::")
    });
    assert!(!unexpected, "{model} {args:?}: {err}");
    assert!(
        !err.contains("bg::mixed-causality") || model.ends_with("hardening_spring.bg"),
        "{model} {args:?}: {err}"
    );
    let again = bgc(&full);
    assert_eq!(
        out.stdout, again.stdout,
        "{model} {args:?}: output differs between runs"
    );
    plausible(model, &stdout(&out));
    stdout(&out)
}

/// Nothing implausible is printed: no non-number, no solver name.
fn plausible(model: &str, text: &str) {
    for word in ["NaN", "inf", "unknown", "Var(", "Tear("] {
        let bare = text
            .split(|c: char| !c.is_alphanumeric() && c != '(' && c != '_')
            .any(|w| w == word);
        assert!(!bare, "{model}: output holds `{word}`");
    }
}

#[test]
fn every_model_checks_and_every_emitter_is_snapshotted() {
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

        let dot = emit(&model, &["--emit", "dot"]);
        insta::assert_snapshot!("dot", dot);
        render(&model, dot.as_bytes());

        insta::assert_snapshot!("text", emit(&model, &["--emit", "text"]));
        insta::assert_snapshot!("latex", emit(&model, &["--emit", "latex"]));
        insta::assert_snapshot!("rust", emit(&model, &["--emit", "rust"]));
        insta::assert_snapshot!("c", emit(&model, &["--emit", "c"]));
        let json = emit(&model, &["--emit", "json"]);
        schema(&model, &json);
        sparse_matches_dense(
            &model,
            &json,
            &emit(&model, &["--emit", "json", "--fsm", "sparse"]),
        );
        insta::assert_snapshot!("json", json);
        // The residuals beyond one per detector, and what they tell apart.
        insta::assert_snapshot!(
            "best",
            emit(&model, &["--emit", "text", "--residuals", "best"])
        );
        compile_latex(&model, &emit(&model, &["--emit", "latex", "--standalone"]));
        let causality = bgc(&["causality", &model]);
        assert_eq!(code(&causality), 0);
        insta::assert_snapshot!("causality", stdout(&causality));
    });
}

/// The JSON contract of the README, checked field by field.
fn schema(model: &str, text: &str) {
    let v: serde_json::Value =
        serde_json::from_str(text).unwrap_or_else(|e| panic!("{model}: invalid JSON: {e}"));
    let sensors = v["sensors"].as_array().expect("sensors");
    let arrs = v["arrs"].as_array().expect("arrs");
    assert_eq!(arrs.len(), sensors.len(), "{model}: one ARR per sensor");
    assert!(v["model"].is_string() && v["parameters"].is_object() && v["inputs"].is_array());
    for s in sensors {
        assert!(
            matches!(s["kind"].as_str(), Some("De" | "Df" | "Dq" | "Dp")),
            "{model}: {s}"
        );
    }
    for e in v["state_equations"].as_array().expect("state_equations") {
        assert!(e["state"].is_string() && e["rhs"].is_string());
    }
    for o in v["outputs"].as_array().expect("outputs") {
        assert!(o["sensor"].is_string() && o["expr"].is_string());
    }
    // Only the warnings a model carries on purpose (see `emit`).
    for d in v["diagnostics"].as_array().expect("diagnostics") {
        assert!(
            d["code"] == "bg::mixed-causality" || d["code"] == "bg::shared-parameter",
            "{model}: {d}"
        );
        assert_eq!(d["severity"], "warning", "{model}: {d}");
    }
    let residuals = v["fsm"]["residuals"].as_array().expect("residuals");
    assert_eq!(residuals.len(), arrs.len());
    for (i, arr) in arrs.iter().enumerate() {
        assert_eq!(arr["name"], format!("ARR{}", i + 1));
        for key in ["junction", "sensor", "expr"] {
            assert!(arr[key].is_string(), "{model}: ARR{} lacks {key}", i + 1);
        }
        assert!(arr["components"].is_array());
        assert!(
            arr["without"].as_array().is_some_and(Vec::is_empty),
            "{model}: one detector's ARR of the whole model"
        );
        for r in arr["reads"].as_array().expect("reads") {
            assert!(
                r["signal"].is_string() && r["orders"].is_array() && r["integral"].is_boolean()
            );
        }
    }
    isolability(model, &v);
    for row in v["fsm"]["rows"].as_array().expect("rows") {
        let signature = row["signature"].as_array().expect("signature");
        assert_eq!(signature.len(), residuals.len());
        let db = signature.iter().any(|b| b == 1);
        assert_eq!(row["Db"] == 1, db, "{model}: Db of {}", row["component"]);
        for key in ["component", "kind"] {
            assert!(row[key].is_string());
        }
        assert!(row["parameters"].is_array() && row["signals"].is_array());
    }
}

/// The classes partition the FSM's rows, the selected ones are the signatures', and the
/// structural ones are at least as fine.
fn isolability(model: &str, v: &serde_json::Value) {
    let iso = &v["isolability"];
    assert_eq!(iso["residuals"], "per-sensor");
    assert!(iso["candidates"].is_null());
    let rows: Vec<(&str, &serde_json::Value)> = v["fsm"]["rows"]
        .as_array()
        .expect("rows")
        .iter()
        .map(|r| (r["component"].as_str().expect("name"), &r["signature"]))
        .collect();
    let class_of = |set: &str| {
        let mut of = std::collections::HashMap::new();
        for (k, class) in iso[set]["classes"]
            .as_array()
            .expect("classes")
            .iter()
            .enumerate()
        {
            for name in class.as_array().expect("class") {
                assert!(of.insert(name.as_str().expect("name"), Some(k)).is_none());
            }
        }
        for name in iso[set]["undetectable"].as_array().expect("undetectable") {
            assert!(of.insert(name.as_str().expect("name"), None).is_none());
        }
        assert_eq!(of.len(), rows.len(), "{model}: {set} covers every row once");
        of
    };
    let (selected, possible) = (class_of("selected"), class_of("possible"));
    for &(a, sa) in &rows {
        for &(b, sb) in &rows {
            let detected = sa.as_array().expect("signature").iter().any(|x| x == 1);
            assert_eq!(
                detected && selected[a] == selected[b],
                detected && sa == sb,
                "{model}: {a} and {b}"
            );
            if possible[a].is_some() && possible[a] == possible[b] {
                assert!(
                    selected[a] == selected[b],
                    "{model}: the ARRs tell {a} from {b}, the structure cannot"
                );
            }
        }
    }
}

/// `--fsm sparse` lists, for each row, the ARRs where the dense signature has a 1.
fn sparse_matches_dense(model: &str, dense: &str, sparse: &str) {
    let d: serde_json::Value = serde_json::from_str(dense).expect("dense JSON");
    let s: serde_json::Value = serde_json::from_str(sparse).expect("sparse JSON");
    let names = d["fsm"]["residuals"].as_array().expect("residuals").clone();
    for (dr, sr) in d["fsm"]["rows"]
        .as_array()
        .expect("rows")
        .iter()
        .zip(s["fsm"]["rows"].as_array().expect("rows"))
    {
        assert!(
            sr.get("signature").is_none(),
            "{model}: sparse rows hold no signature"
        );
        let listed: Vec<&serde_json::Value> = dr["signature"]
            .as_array()
            .expect("signature")
            .iter()
            .zip(&names)
            .filter(|(bit, _)| **bit == 1)
            .map(|(_, n)| n)
            .collect();
        let arrs: Vec<&serde_json::Value> = sr["arrs"].as_array().expect("arrs").iter().collect();
        assert_eq!(listed, arrs, "{model}: {}", dr["component"]);
        assert_eq!(dr["Db"], sr["Db"]);
        assert_eq!(dr["Ib"], sr["Ib"]);
    }
}

/// A tool the test needs: present, or skipped with a note outside CI, or a failure under CI.
fn tool(name: &str) -> bool {
    let found = Command::new(name)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    if !found {
        assert!(
            std::env::var_os("CI").is_none(),
            "`{name}` is needed under CI (.ci/run installs it)"
        );
        eprintln!("note: `{name}` not found; that check is skipped");
    }
    found
}

/// Compiles a standalone LaTeX document with pdflatex, and checks that no line is too wide.
fn compile_latex(model: &str, tex: &str) {
    if !tool("pdflatex") {
        return;
    }
    let dir = scratch(&format!("latex-{}", model.replace('/', "_")));
    std::fs::write(dir.join("arr.tex"), tex).expect("write tex");
    let out = Command::new("pdflatex")
        .args(["-interaction=nonstopmode", "-halt-on-error", "arr.tex"])
        .current_dir(&dir)
        .stdin(Stdio::null())
        .output()
        .expect("pdflatex runs");
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && dir.join("arr.pdf").exists(),
        "{model}: pdflatex failed:\n{log}"
    );
    // Every equation stays within the margins: long ones are broken or named.
    assert!(
        !log.contains("Overfull \\hbox"),
        "{model}: a line runs past the margin:\n{log}"
    );
    std::fs::remove_dir_all(&dir).ok();
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
