//! The models every end-to-end test runs over: `models/*.bg`, sorted by name.

use std::path::{Path, PathBuf};

/// Every `.bg` file in `models/`, sorted.
pub(crate) fn models() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("models/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "bg"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 6, "models/ should hold the reference models");
    paths
}
