//! The house, drawn from the imports: every source file of every crate, an edge for each
//! path it names through `crate::` or `super::`, resolved to the file that holds the module.
//! The house stands when no edge runs back up (from a file to the crate root or to the
//! `mod.rs` of a folder that holds it: parents dispatch to their children, never the other
//! way) and no files import each other round a circle.
//!
//! Run `cargo test -p bondgraph-core --test house -- --nocapture` to print the drawing.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A source file, as its path under the workspace's `crates/`.
type File = String;

/// One crate's files: the module path of each (`["fdi", "fsm"]`) and its text.
struct Crate {
    name: String,
    src: PathBuf,
    files: BTreeMap<Vec<String>, (File, String)>,
}

fn crates() -> Vec<Crate> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    let mut dirs: Vec<_> = fs::read_dir(root.join("crates"))
        .expect("crates/")
        .map(|e| e.expect("entry").path())
        .collect();
    dirs.sort();
    for dir in dirs {
        let src = dir.join("src");
        if !src.is_dir() {
            continue;
        }
        let name = dir
            .file_name()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        let mut files = BTreeMap::new();
        walk(&src, &src, &name, &mut files);
        out.push(Crate { name, src, files });
    }
    out
}

fn walk(src: &Path, dir: &Path, krate: &str, files: &mut BTreeMap<Vec<String>, (File, String)>) {
    let mut entries: Vec<_> = fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            walk(src, &path, krate, files);
            continue;
        }
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let relative = path.strip_prefix(src).expect("under src");
        let mut module: Vec<String> = relative
            .iter()
            .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
            .collect();
        if matches!(
            module.last().map(String::as_str),
            Some("mod" | "lib" | "main")
        ) {
            module.pop();
        }
        if module.first().is_some_and(|m| m == "bin") {
            continue;
        }
        let text = fs::read_to_string(&path).expect("source");
        let name = format!("{krate}/src/{}", relative.to_string_lossy());
        files.insert(module, (name, text));
    }
}

/// The paths a text names after `crate::` or `super::`, and in a folder's root file after the
/// name of one of its `children` (a re-export, `pub use child::Item`, is the folder's door and
/// not a use), with the module each is relative to and whether it stands in a test module
/// (`#[cfg(test)]` onwards).
fn paths(text: &str, children: &[String]) -> Vec<(Anchor, Vec<String>, bool)> {
    let tests_from = text.find("#[cfg(test)]\nmod").unwrap_or(text.len());
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        // Skip line comments, where paths are prose.
        if bytes[i..].starts_with(b"//") {
            i += bytes[i..]
                .iter()
                .position(|&b| b == b'\n')
                .unwrap_or(bytes.len() - i);
            continue;
        }
        if [&b"pub use "[..], b"pub(crate) use "]
            .iter()
            .any(|w| bytes[i..].starts_with(w))
        {
            i += bytes[i..]
                .iter()
                .position(|&b| b == b';')
                .unwrap_or(bytes.len() - i);
            continue;
        }
        let word_start = i == 0
            || !(bytes[i - 1].is_ascii_alphanumeric()
                || bytes[i - 1] == b'_'
                || bytes[i - 1] == b':');
        let child = children.iter().find(|c| {
            bytes[i..].starts_with(c.as_bytes()) && bytes[i + c.len()..].starts_with(b"::")
        });
        let anchor = if !word_start {
            None
        } else if child.is_some() {
            Some((Anchor::Own, 0))
        } else if bytes[i..].starts_with(b"crate::") {
            Some((Anchor::Crate, "crate::".len()))
        } else if bytes[i..].starts_with(b"super::") {
            let mut ups = 0;
            let mut j = i;
            while bytes[j..].starts_with(b"super::") {
                ups += 1;
                j += "super::".len();
            }
            Some((Anchor::Super(ups), j - i))
        } else {
            None
        };
        match anchor {
            Some((anchor, skip)) => {
                let mut trees = Vec::new();
                let end = tree(text, i + skip, Vec::new(), &mut trees);
                let in_test = i >= tests_from;
                out.extend(trees.into_iter().map(|p| (anchor, p, in_test)));
                i = end.max(i + 1);
            }
            None => i += 1,
        }
    }
    out
}

#[derive(Clone, Copy)]
enum Anchor {
    Crate,
    Own,
    Super(usize),
}

/// Reads a use tree at `at` (`a::b`, `a::{b, c::d}`, `*`), pushing each full path; returns
/// where it ends.
fn tree(text: &str, mut at: usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let bytes = text.as_bytes();
    let mut path = prefix;
    loop {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if at < bytes.len() && bytes[at] == b'{' {
            at += 1;
            loop {
                at = tree(text, at, path.clone(), out);
                while at < bytes.len() && (bytes[at].is_ascii_whitespace() || bytes[at] == b',') {
                    at += 1;
                }
                if at >= bytes.len() || bytes[at] == b'}' {
                    return at + 1;
                }
            }
        }
        let start = at;
        while at < bytes.len() && (bytes[at].is_ascii_alphanumeric() || bytes[at] == b'_') {
            at += 1;
        }
        if at < bytes.len() && bytes[at] == b'*' && start == at {
            at += 1;
        }
        if start < at {
            path.push(text[start..at].to_string());
        }
        if bytes[at..].starts_with(b"::") {
            at += 2;
            continue;
        }
        out.push(path);
        return at;
    }
}

/// The file holding the deepest module that `path` (from the crate root) names.
fn resolve(krate: &Crate, path: &[String]) -> Vec<String> {
    (0..=path.len())
        .rev()
        .map(|n| path[..n].to_vec())
        .find(|m| krate.files.contains_key(m))
        .unwrap_or_default()
}

/// Every edge: (from file, to file, runs back up, from a test module).
fn edges(krate: &Crate) -> BTreeSet<(Vec<String>, Vec<String>, bool)> {
    let mut out = BTreeSet::new();
    for (module, (name, text)) in &krate.files {
        let is_folder = ["mod.rs", "lib.rs", "main.rs"]
            .iter()
            .any(|f| name.ends_with(f));
        let children: Vec<String> = krate
            .files
            .keys()
            .filter(|m| is_folder && m.len() == module.len() + 1 && m.starts_with(module))
            .map(|m| m[module.len()].clone())
            .collect();
        // A whole file of tests (`mod tests;`) is a test module, but its `super` is its parent.
        let test_file = name.ends_with("/tests.rs");
        for (anchor, path, inline_test) in paths(text, &children) {
            let in_test = inline_test || test_file;
            let base: Vec<String> = match anchor {
                Anchor::Crate => Vec::new(),
                Anchor::Own => module.clone(),
                // In a test module `super` is the file itself.
                Anchor::Super(ups) => {
                    let ups = ups - usize::from(inline_test);
                    module[..module.len().saturating_sub(ups)].to_vec()
                }
            };
            let full: Vec<String> = base.into_iter().chain(path).collect();
            let target = resolve(krate, &full);
            // Test modules may use the crate's front door, as a user does: `crate::compile`
            // there is the function the root re-exports, not the module of that name.
            let front_door = in_test && (target.is_empty() || full.len() == 1);
            if &target == module || front_door {
                continue;
            }
            // The crate root is the door for users; inside, the real module is named.
            let up = target.is_empty() && !module.is_empty();
            out.insert((module.clone(), target, up));
        }
    }
    out
}

/// The strongly connected components of more than one file (Tarjan's algorithm).
fn circles(
    nodes: &[Vec<String>],
    edges: &BTreeSet<(Vec<String>, Vec<String>, bool)>,
) -> Vec<Vec<Vec<String>>> {
    let index: BTreeMap<&Vec<String>, usize> =
        nodes.iter().enumerate().map(|(k, n)| (n, k)).collect();
    let mut next = vec![Vec::new(); nodes.len()];
    for (from, to, _) in edges {
        if let (Some(&a), Some(&b)) = (index.get(from), index.get(to)) {
            next[a].push(b);
        }
    }
    struct T {
        next: Vec<Vec<usize>>,
        order: Vec<Option<usize>>,
        low: Vec<usize>,
        stack: Vec<usize>,
        on: Vec<bool>,
        counter: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(t: &mut T, v: usize) {
        t.order[v] = Some(t.counter);
        t.low[v] = t.counter;
        t.counter += 1;
        t.stack.push(v);
        t.on[v] = true;
        for w in t.next[v].clone() {
            match t.order[w] {
                None => {
                    visit(t, w);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(o) if t.on[w] => t.low[v] = t.low[v].min(o),
                Some(_) => {}
            }
        }
        if Some(t.low[v]) == t.order[v] {
            let mut scc = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on[w] = false;
                scc.push(w);
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                t.out.push(scc);
            }
        }
    }
    let n = nodes.len();
    let mut t = T {
        next,
        order: vec![None; n],
        low: vec![0; n],
        stack: Vec::new(),
        on: vec![false; n],
        counter: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.order[v].is_none() {
            visit(&mut t, v);
        }
    }
    t.out
        .into_iter()
        .map(|scc| {
            let mut files: Vec<_> = scc.into_iter().map(|k| nodes[k].clone()).collect();
            files.sort();
            files
        })
        .collect()
}

#[test]
fn no_import_runs_back_up_and_no_circle() {
    let mut problems = Vec::new();
    for krate in crates() {
        let name = |m: &Vec<String>| krate.files[m].0.clone();
        let edges = edges(&krate);
        let nodes: Vec<Vec<String>> = krate.files.keys().cloned().collect();
        println!(
            "{} ({} files, {} imports)",
            krate.name,
            nodes.len(),
            edges.len()
        );
        for (from, to, up) in &edges {
            println!(
                "  {} -> {}{}",
                name(from),
                name(to),
                if *up { "   (back up)" } else { "" }
            );
            if *up {
                problems.push(format!("{} imports back up from {}", name(from), name(to)));
            }
        }
        for circle in circles(&nodes, &edges) {
            let files: Vec<_> = circle.iter().map(name).collect();
            problems.push(format!("circle: {}", files.join(" <-> ")));
        }
        let _ = &krate.src;
    }
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}
