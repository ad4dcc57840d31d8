//! Running the `bgc` binary the way a user does, from the workspace root.

#![allow(dead_code)]

mod models;
pub(crate) mod mutate;

#[allow(unused_imports)]
pub(crate) use models::models;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The workspace root, where `models/` and `tests/` are.
pub(crate) fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A path relative to the workspace root, with `/` separators, as shown in diagnostics.
pub(crate) fn relative(path: &Path) -> String {
    let root = root().canonicalize().expect("workspace root");
    let path = path.canonicalize().expect("test file");
    path.strip_prefix(&root)
        .expect("inside the workspace")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join("/")
}

/// Runs bgc with `args` from the workspace root, colours off.
pub(crate) fn bgc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bgc"))
        .args(args)
        .current_dir(root())
        .env("NO_COLOR", "1")
        .env_remove("FORCE_COLOR")
        .env_remove("CLICOLOR_FORCE")
        .stdin(Stdio::null())
        .output()
        .expect("bgc runs")
}

/// Standard output as text.
pub(crate) fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Standard error as text.
/// Standard error as text, with the lines miette wraps a message into joined again (a
/// continuation line starts with `│` after the indent), so that a test can look for a phrase.
pub(crate) fn stderr(output: &Output) -> String {
    let text = String::from_utf8_lossy(&output.stderr);
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        match trimmed.strip_prefix("│ ") {
            Some(rest) if line.len() - trimmed.len() == 2 && out.ends_with('\n') => {
                out.pop();
                // A line broken after a hyphen (`non-` / `negative`) joins without a space.
                if !out.ends_with('-') {
                    out.push(' ');
                }
                out.push_str(rest);
            }
            _ => out.push_str(line),
        }
    }
    out
}

/// The exit code; a signal or a panic (101) fails the test at the call site.
pub(crate) fn code(output: &Output) -> i32 {
    output.status.code().unwrap_or(-1)
}

/// Whether `report` names `file:LINE:COL` somewhere.
pub(crate) fn names_line_and_column(report: &str, file: &str) -> bool {
    let located = format!("{file}:");
    report.match_indices(&located).any(|(at, _)| {
        let mut parts = report[at + located.len()..].splitn(3, ':');
        let number = |s: Option<&str>| {
            s.is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
        };
        number(parts.next()) && number(parts.next())
    })
}

/// A fresh directory for one test's files, named after the test, this process and a count
/// (the tests of one binary run in one process, some of them for the same name).
pub(crate) fn scratch(name: &str) -> PathBuf {
    static MADE: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("bgc-{name}-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
