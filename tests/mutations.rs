//! Random mutations of the valid models: deleted, duplicated and swapped lines, swapped tokens,
//! truncation, random bytes. None may crash bgc, and every rejection must say where.
//!
//! The generator is a fixed-seed SplitMix64, so a failure reproduces exactly; the failing
//! input is printed.
//!
//! The suite runs a sample sized to stay in seconds (`BGC_MUTANTS`, default 120 library
//! mutants and 3 command-line mutants per model); the campaign runs many more with the same
//! code, e.g. `BGC_MUTANTS=20000 cargo test --release -p bgc --test mutations`, and prints
//! how many it ran.

mod common;

use bondgraph_core::diagnostic::LineIndex;
use bondgraph_core::{Derive, Options};
use common::{bgc, code, names_line_and_column, stderr};

/// SplitMix64: small, fast, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

fn models() -> Vec<(String, Vec<u8>)> {
    common::models()
        .into_iter()
        .map(|p| {
            let name = p.file_name().expect("name").to_string_lossy().into_owned();
            (name, std::fs::read(&p).expect("readable"))
        })
        .collect()
}

/// One random mutation of `text`, and what it was.
fn mutate(text: &[u8], rng: &mut Rng) -> (Vec<u8>, &'static str) {
    let lines: Vec<&[u8]> = text.split_inclusive(|&b| b == b'\n').collect();
    let mut lines: Vec<Vec<u8>> = lines.into_iter().map(<[u8]>::to_vec).collect();
    let what = match rng.below(8) {
        0 => {
            lines.remove(rng.below(lines.len()));
            "deleted a line"
        }
        1 => {
            let i = rng.below(lines.len());
            let line = lines[i].clone();
            lines.insert(rng.below(lines.len() + 1), line);
            "duplicated a line"
        }
        2 => {
            let (i, j) = (rng.below(lines.len()), rng.below(lines.len()));
            lines.swap(i, j);
            "swapped two lines"
        }
        3 => return (swap_tokens(text, rng), "swapped two tokens"),
        4 => return (text[..rng.below(text.len() + 1)].to_vec(), "truncated"),
        5 => {
            let mut out = text.to_vec();
            for _ in 0..=rng.below(4) {
                let at = rng.below(out.len());
                out[at] = rng.next() as u8;
            }
            return (out, "replaced bytes with random ones");
        }
        6 => {
            let mut out = text.to_vec();
            let at = rng.below(out.len() + 1);
            let noise: Vec<u8> = (0..=rng.below(16)).map(|_| rng.next() as u8).collect();
            out.splice(at..at, noise);
            return (out, "inserted random bytes");
        }
        _ => {
            // A printable character from the language's alphabet, where it may not belong.
            let alphabet = b"()[]{}=:,->< 01#\"\n*^/+.e_xyzRCI";
            let mut out = text.to_vec();
            let at = rng.below(out.len());
            out[at] = alphabet[rng.below(alphabet.len())];
            return (out, "replaced a byte with a token character");
        }
    };
    (lines.concat(), what)
}

fn swap_tokens(text: &[u8], rng: &mut Rng) -> Vec<u8> {
    let tokens: Vec<&[u8]> = text
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    let (i, j) = (rng.below(tokens.len()), rng.below(tokens.len()));
    let mut swapped = tokens.clone();
    swapped.swap(i, j);
    // Keep line structure: rebuild with the original separators.
    let mut out = Vec::with_capacity(text.len());
    let mut k = 0;
    let mut in_token = false;
    for &b in text {
        if b.is_ascii_whitespace() {
            in_token = false;
            out.push(b);
        } else if !in_token {
            in_token = true;
            out.extend_from_slice(swapped[k]);
            k += 1;
        }
    }
    out
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
    if !c.has_errors() {
        let code = rust::tokens(c).to_string();
        assert!(
            !code.contains("NAN"),
            "{name} ({what}): the Rust reads something it has no value for\n{text}\n{code}"
        );
        outputs.push(code);
    }
    for output in outputs {
        for word in IMPLAUSIBLE {
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

#[test]
fn mutated_models_never_crash_the_cli_and_every_rejection_names_line_and_column() {
    let dir = std::env::temp_dir().join(format!("bgc-mutants-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
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
                    format!(
                        "{name} ({what}): {report}\n{}",
                        String::from_utf8_lossy(&mutant)
                    )
                };
                match code(&out) {
                    0 => {}
                    1 => assert!(
                        names_line_and_column(&report, shown) && report.contains('│'),
                        "rejection without a location: {}",
                        context()
                    ),
                    other => panic!("exit code {other}: {}", context()),
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
