//! Random mutations of the valid models: deleted, duplicated and swapped lines, swapped tokens,
//! truncation, random bytes. None may crash bgc, and every rejection must say where.
//!
//! The generator is a fixed-seed SplitMix64, so a failure reproduces exactly; the failing
//! input is printed.
//!
//! The suite runs a sample sized to stay in seconds (`BGC_MUTANTS`, default 120 library
//! mutants and 3 command-line mutants per model); the campaign runs many more with the same
//! code, e.g. `BGC_MUTANTS=20000 cargo test --release -p bgc --test suite mutations::`, and
//! prints how many it ran.

use crate::common::mutate::{mutate, Rng};
use crate::common::{bgc, code, names_line_and_column, scratch, stderr};
use bondgraph_core::diagnostic::LineIndex;
use bondgraph_core::{Derive, Options};

fn models() -> Vec<(String, Vec<u8>)> {
    crate::common::models()
        .into_iter()
        .map(|p| {
            let name = p.file_name().expect("name").to_string_lossy().into_owned();
            (name, std::fs::read(&p).expect("readable"))
        })
        .collect()
}

/// Every diagnostic points inside the text, on character boundaries, so line and column exist.
fn check_located(name: &str, what: &str, bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return; // Not text: the CLI reports it; checked through the binary below.
    };
    let options = Options {
        derive: Derive::Everything,
        simplify: None,
        ..Options::default()
    };
    let diagnostics = match bondgraph_core::compile(text, name, &options) {
        Ok(out) => {
            assert_plausible(name, what, text, &out.compiled);
            out.compiled.diagnostics
        }
        Err(diagnostics) => {
            assert!(
                diagnostics.has_errors(),
                "{name} ({what}): rejected without an error\n{text}"
            );
            diagnostics
        }
    };
    let index = LineIndex::new(text);
    for d in diagnostics.iter() {
        let ok = d.span.start <= d.span.end
            && d.span.end <= text.len()
            && text.is_char_boundary(d.span.start)
            && text.is_char_boundary(d.span.end);
        assert!(
            ok,
            "{name} ({what}): span {:?} outside the text\n{text}",
            d.span
        );
        let at = index.line_col(text, d.span.start);
        assert!(at.line >= 1 && at.col >= 1);
    }
}

/// Words that must never reach an output: non-numbers and the solver's names.
const IMPLAUSIBLE: [&str; 5] = ["NaN", "inf", "unknown", "Var(", "Tear("];

/// Every emitter's output on a valid mutant holds nothing implausible.
fn assert_plausible(name: &str, what: &str, text: &str, c: &bondgraph_core::Compiled) {
    use bondgraph_codegen::{dot, json, latex, rust, text as summary};
    let mut outputs = vec![
        summary::emit(c),
        json::emit(c),
        latex::emit(c, true),
        dot::emit(c),
        summary::causality(c),
    ];
    // Rust is written only for a model without errors (the CLI refuses it otherwise); its
    // tokens, unformatted (formatting is the same for every model, and costs).
    // Code it cannot compute with is refused (an error, exit 1), never written with a NaN.
    if let (false, Ok(code)) = (c.has_errors(), rust::tokens(c)) {
        let code = code.to_string();
        assert!(
            !code.contains("NAN"),
            "{name} ({what}): the Rust reads something it has no value for\n{text}\n{code}"
        );
        outputs.push(code);
    }
    // A word the model itself holds (a detector named `unknown`) is the user's, not bgc's.
    let own = |word: &str| {
        text.split(|ch: char| !ch.is_alphanumeric() && ch != '_')
            .any(|w| w == word)
    };
    for output in outputs {
        for word in IMPLAUSIBLE.into_iter().filter(|w| !own(w)) {
            // Names the user chose may contain these letters; only bare words count.
            let bare = output
                .split(|ch: char| !ch.is_alphanumeric() && ch != '(' && ch != '_')
                .any(|w| w == word);
            assert!(
                !bare,
                "{name} ({what}): output holds `{word}`\n{text}\n{output}"
            );
        }
    }
}

/// How many mutants of each model the library sees (`BGC_MUTANTS`, default 120); the command
/// line sees a fortieth of them (at least 3), each through three commands.
fn mutants_per_model() -> usize {
    std::env::var("BGC_MUTANTS")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(120)
}

#[test]
fn mutated_models_never_crash_the_library_and_every_error_is_located() {
    let mut rng = Rng(0x6267_6321);
    let mut rejected = 0;
    let mut total = 0;
    for (name, text) in models() {
        for _ in 0..mutants_per_model() {
            let (mutant, what) = mutate(&text, &mut rng);
            let outcome = std::panic::catch_unwind(|| check_located(&name, what, &mutant));
            if let Err(panic) = outcome {
                eprintln!(
                    "{name} ({what}) crashed on:\n{}",
                    String::from_utf8_lossy(&mutant)
                );
                std::panic::resume_unwind(panic);
            }
            total += 1;
            let options = Options {
                derive: Derive::Nothing,
                simplify: None,
                ..Options::default()
            };
            if std::str::from_utf8(&mutant).map_or(true, |t| {
                bondgraph_core::compile(t, &name, &options).is_err()
            }) {
                rejected += 1;
            }
        }
    }
    eprintln!("{total} mutants through the library, {rejected} rejected");
    // The mutations must actually exercise the error paths.
    assert!(
        rejected * 2 > total,
        "only {rejected} of {total} mutants rejected"
    );
}

/// The length of the longest line of `text`, in bytes.
fn longest_line(text: &[u8]) -> usize {
    text.split(|&b| b == b'\n')
        .map(<[u8]>::len)
        .max()
        .unwrap_or(0)
}

#[test]
fn mutated_models_never_crash_the_cli_and_every_rejection_names_line_and_column() {
    let dir = scratch("mutants");
    let mut rng = Rng(0x5eed);
    for (name, text) in models() {
        for n in 0..(mutants_per_model() / 40).max(3) {
            let (mutant, what) = mutate(&text, &mut rng);
            let path = dir.join(format!("{n}-{name}"));
            std::fs::write(&path, &mutant).expect("write mutant");
            let shown = path.to_str().expect("utf-8 temp path");
            for args in [
                vec!["check", shown],
                vec![shown, "--emit", "dot"],
                vec![shown, "--emit", "json"],
            ] {
                let out = bgc(&args);
                let report = stderr(&out);
                let context = || {
                    let shown = String::from_utf8_lossy(&mutant);
                    let shown: String = shown.chars().take(4_000).collect();
                    let report: String = report.chars().take(4_000).collect();
                    format!("{name} ({what}): {report}\n{shown}")
                };
                match code(&out) {
                    0 => {}
                    // A line past 4,000 characters is located, not quoted.
                    1 => assert!(
                        names_line_and_column(&report, shown)
                            && (report.contains('│') || longest_line(&mutant) > 4_000),
                        "rejection without a location: {}",
                        context()
                    ),
                    other => panic!("exit code {other}: {}", context()),
                }
                // The same input, the same bytes: nothing but the model decides the output
                // (checked on one mutant per model here; on every one in a campaign).
                if n == 0 || std::env::var_os("BGC_MUTANTS").is_some() {
                    let again = bgc(&args);
                    assert_eq!(
                        (code(&again), &again.stdout, &again.stderr),
                        (code(&out), &out.stdout, &out.stderr),
                        "a second run differs: {}",
                        context()
                    );
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
