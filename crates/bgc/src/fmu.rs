//! `bgc MODEL --emit fmu -o FILE.fmu`: an FMI 3.0 co-simulation FMU of the residual
//! generator. The C code and the FMI functions (bondgraph-codegen) are compiled for this
//! machine by its C compiler (`$CC`, else `cc`; `-O2`, else `$CFLAGS`) into
//! `binaries/PLATFORM/ID.so`, and shipped with their sources and build description, so that
//! an FMU for another platform (a Windows PC, a dSPACE target) is built from the same files.

use std::path::{Path, PathBuf};
use std::process::Command;

use bondgraph_codegen::fmu::FmuSources;
use bondgraph_core::Compiled;

use crate::report::{self, Failure};

/// Writes the model's FMU to `output`.
pub(crate) fn write(c: &Compiled, output: Option<&Path>) -> Result<(), Failure> {
    let Some(path) = output.filter(|p| p.extension().is_some_and(|e| e == "fmu")) else {
        return Err(report::usage(
            "--emit fmu writes a zip archive: give -o a file name ending in .fmu",
        ));
    };
    let tool = format!("bgc {}", env!("CARGO_PKG_VERSION"));
    let sources = bondgraph_codegen::fmu::emit(c, &tool)
        .map_err(|why| report::refused(format!("{}: cannot write an FMU: {why}", c.file_name)))?;
    let platform = Platform::here().ok_or_else(|| {
        report::refused(format!(
            "an FMU's binary is built here for Linux and macOS on x86-64 or ARM64, not {} on {}",
            std::env::consts::ARCH,
            std::env::consts::OS
        ))
    })?;
    let binary = compile(&sources, &platform)?;
    let files = files(&sources, &platform, binary);
    let archive = crate::zip::archive(&files)
        .map_err(|e| report::refused(format!("{}: {e}", path.display())))?;
    crate::output::replace(path, &archive)
        .map_err(|e| report::usage(format!("cannot write {}: {e}", path.display())))
}

/// Where an FMU keeps the binary for this machine (FMI 3.0's platform tuple) and how it is
/// named.
struct Platform {
    tuple: &'static str,
    extension: &'static str,
}

impl Platform {
    fn here() -> Option<Platform> {
        use std::env::consts::{ARCH, OS};
        let (tuple, extension) = match (ARCH, OS) {
            ("x86_64", "linux") => ("x86_64-linux", "so"),
            ("aarch64", "linux") => ("aarch64-linux", "so"),
            ("x86_64", "macos") => ("x86_64-darwin", "dylib"),
            ("aarch64", "macos") => ("aarch64-darwin", "dylib"),
            _ => return None,
        };
        Some(Platform { tuple, extension })
    }
}

/// The archive's files, in a fixed order.
fn files(sources: &FmuSources, platform: &Platform, binary: Vec<u8>) -> Vec<(String, Vec<u8>)> {
    let id = &sources.identifier;
    vec![
        (
            "modelDescription.xml".into(),
            sources.model_description.clone().into_bytes(),
        ),
        (
            format!("binaries/{}/{id}.{}", platform.tuple, platform.extension),
            binary,
        ),
        (
            "sources/buildDescription.xml".into(),
            sources.build_description.clone().into_bytes(),
        ),
        (
            format!("sources/{id}.h"),
            sources.code.header.clone().into_bytes(),
        ),
        (
            format!("sources/{id}.c"),
            sources.code.source.clone().into_bytes(),
        ),
        (
            format!("sources/{}", sources.wrapper_name),
            sources.wrapper.clone().into_bytes(),
        ),
    ]
}

/// A directory of this process's own under the system's temporary one, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> std::io::Result<Scratch> {
        static MADE: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("bgc-fmu-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        Ok(Scratch(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The C compiler's flags beside `-std=c99 -fPIC -shared`: `$CFLAGS` where it is set (a
/// target's `-march`, another optimisation level), else `-O2`.
fn flags() -> Vec<String> {
    let set = std::env::var("CFLAGS").unwrap_or_default();
    let words: Vec<String> = set.split_whitespace().map(str::to_string).collect();
    if words.is_empty() {
        vec!["-O2".to_string()]
    } else {
        words
    }
}

/// The FMU's shared library, built by this machine's C compiler from the sources.
fn compile(sources: &FmuSources, platform: &Platform) -> Result<Vec<u8>, Failure> {
    let cannot = |what: String| report::refused(format!("cannot build the FMU's binary: {what}"));
    let dir = Scratch::new().map_err(|e| cannot(format!("a temporary directory: {e}")))?;
    let id = &sources.identifier;
    let write = |name: &str, text: &str| {
        std::fs::write(dir.0.join(name), text).map_err(|e| cannot(format!("{name}: {e}")))
    };
    write(&format!("{id}.h"), &sources.code.header)?;
    write(&format!("{id}.c"), &sources.code.source)?;
    write(&sources.wrapper_name, &sources.wrapper)?;
    let compiler = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
    let library = format!("{id}.{}", platform.extension);
    let out = Command::new(&compiler)
        .current_dir(&dir.0)
        .arg("-std=c99")
        .args(flags())
        .args(["-fPIC", "-shared", "-o", &library])
        .arg(format!("{id}.c"))
        .arg(&sources.wrapper_name)
        .arg("-lm")
        .output()
        .map_err(|e| {
            cannot(format!(
                "the C compiler `{compiler}` does not run ({e}): install one (gcc or clang), or \
                 name it in CC"
            ))
        })?;
    if !out.status.success() {
        return Err(cannot(format!(
            "`{compiler}` failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    std::fs::read(dir.0.join(&library)).map_err(|e| cannot(format!("{library}: {e}")))
}
