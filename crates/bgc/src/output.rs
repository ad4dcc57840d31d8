//! The one way bgc writes a file (`-o`, `--plot`, `identify --write`): whole or not at all.
//!
//! The bytes go to a file that has no name yet (Linux's `O_TMPFILE`), which is given a name
//! of this process's own beside the target only once it is complete, and then renamed over
//! the target. So: a reader, or another bgc writing the same file at the same moment, sees
//! either the old file or one whole new one; a full disk or a kill while writing leaves the
//! old file and nothing else (a file without a name vanishes with its process); the name of
//! the staging file does not grow with the target's, so a target of 255 bytes can be
//! written. Where there is no `O_TMPFILE` (another system, a file system without it), the
//! staging file is named from the start and removed on every error bgc sees.

use std::fs::{self, File, Permissions};
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// Most links followed from a target to the file they name, as the kernel allows.
const MOST_LINKS: usize = 40;

/// Replaces the file at `path` with `bytes`, whole or not at all. A link is written through:
/// the file it names (even one that does not exist yet) is replaced, the link stays. What is
/// not a file (`/dev/null`, a named pipe, a terminal) is written in place, as renaming over
/// it would replace a device with a file. A replaced file keeps its permissions.
pub(crate) fn replace(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let target = follow_links(path)?;
    let existing = fs::metadata(&target).ok();
    if existing.as_ref().is_some_and(|m| !m.is_file()) {
        return fs::write(&target, bytes);
    }
    let dir = directory_of(&target);
    let permissions = existing.map(|m| m.permissions());
    let staged = Staged::open(&dir)?;
    staged.fill(bytes, permissions)?.publish(&dir, &target)
}

/// The path `path`'s chain of links ends at, whether or not a file is there.
fn follow_links(path: &Path) -> io::Result<PathBuf> {
    let mut at = path.to_path_buf();
    for _ in 0..MOST_LINKS {
        match fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => {
                let to = fs::read_link(&at)?;
                at = directory_of(&at).join(to);
            }
            _ => return Ok(at),
        }
    }
    Err(io::Error::other(format!(
        "more than {MOST_LINKS} links lead from it, or they loop"
    )))
}

/// The directory a file at `path` is in (`.` for a bare name).
fn directory_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A name in `dir` no other writer uses: this process's id and a count of its own writes.
/// Short, so that it fits where the target's name does.
fn staging_name(dir: &Path) -> PathBuf {
    static WRITES: AtomicU32 = AtomicU32::new(0);
    let n = WRITES.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".bgc-{}-{n}.part", std::process::id()))
}

/// A file being written, before it has its target's name.
enum Staged {
    /// Without a name until it is complete.
    #[cfg(target_os = "linux")]
    Unnamed(File),
    /// Named from the start; removed on every error.
    Named(File, PathBuf),
}

impl Staged {
    /// A new, empty staging file in `dir`.
    fn open(dir: &Path) -> io::Result<Staged> {
        #[cfg(target_os = "linux")]
        if let Ok(file) = unnamed(dir) {
            return Ok(Staged::Unnamed(file));
        }
        let path = staging_name(dir);
        let file = File::options().write(true).create_new(true).open(&path)?;
        Ok(Staged::Named(file, path))
    }

    /// The staging file with `bytes` in it, and `permissions` if a file is being replaced.
    fn fill(self, bytes: &[u8], permissions: Option<Permissions>) -> io::Result<Staged> {
        let result = (|| {
            let mut file = self.file();
            file.write_all(bytes)?;
            file.flush()?;
            match permissions {
                Some(p) => file.set_permissions(p),
                None => Ok(()),
            }
        })();
        match result {
            Ok(()) => Ok(self),
            Err(e) => {
                self.discard();
                Err(e)
            }
        }
    }

    /// Gives the complete file its name `target` (in `dir`), replacing what was there.
    fn publish(self, dir: &Path, target: &Path) -> io::Result<()> {
        let named = match self {
            #[cfg(target_os = "linux")]
            Staged::Unnamed(file) => {
                let name = staging_name(dir);
                link(&file, &name)?;
                name
            }
            Staged::Named(_, path) => path,
        };
        fs::rename(&named, target).inspect_err(|_| {
            let _ = fs::remove_file(&named);
        })
    }

    fn file(&self) -> &File {
        match self {
            #[cfg(target_os = "linux")]
            Staged::Unnamed(file) => file,
            Staged::Named(file, _) => file,
        }
    }

    /// Removes what a failed write left; a file without a name needs nothing.
    fn discard(self) {
        if let Staged::Named(file, path) = self {
            drop(file);
            let _ = fs::remove_file(path);
        }
    }
}

/// A file in `dir` that has no name (`O_TMPFILE`).
#[cfg(target_os = "linux")]
fn unnamed(dir: &Path) -> io::Result<File> {
    use rustix::fs::{Mode, OFlags};
    let flags = OFlags::WRONLY | OFlags::TMPFILE | OFlags::CLOEXEC;
    let fd = rustix::fs::open(dir, flags, Mode::from_raw_mode(0o666))?;
    Ok(File::from(fd))
}

/// Gives the unnamed `file` the name `name`, through its entry in `/proc`: linking the
/// descriptor itself needs a capability users do not have.
#[cfg(target_os = "linux")]
fn link(file: &File, name: &Path) -> io::Result<()> {
    use rustix::fs::{AtFlags, CWD};
    use std::os::fd::AsRawFd as _;
    let proc = format!("/proc/self/fd/{}", file.as_raw_fd());
    rustix::fs::linkat(CWD, proc.as_str(), CWD, name, AtFlags::SYMLINK_FOLLOW)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bgc-output-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("a scratch directory");
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .expect("listed")
            .map(|e| {
                e.expect("an entry")
                    .file_name()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_write_leaves_the_target_and_nothing_else() {
        let dir = scratch("plain");
        let target = dir.join("out.csv");
        replace(&target, b"first").expect("written");
        replace(&target, b"second").expect("rewritten");
        assert_eq!(fs::read(&target).expect("read"), b"second");
        assert_eq!(entries(&dir), ["out.csv"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = scratch("mode");
        let target = dir.join("secret.csv");
        fs::write(&target, "old").expect("written");
        fs::set_permissions(&target, Permissions::from_mode(0o600)).expect("chmod");
        replace(&target, b"new").expect("rewritten");
        let mode = fs::metadata(&target).expect("stat").permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_even_dangling_is_written_through() {
        let dir = scratch("link");
        std::os::unix::fs::symlink("real.csv", dir.join("link.csv")).expect("linked");
        replace(&dir.join("link.csv"), b"data").expect("written");
        let link = fs::symlink_metadata(dir.join("link.csv")).expect("stat");
        assert!(link.file_type().is_symlink(), "the link was replaced");
        assert_eq!(fs::read(dir.join("real.csv")).expect("read"), b"data");
    }

    #[test]
    fn a_name_of_255_bytes_is_written() {
        let dir = scratch("long");
        let target = dir.join(format!("{}.csv", "a".repeat(251)));
        replace(&target, b"data").expect("written");
        assert_eq!(fs::read(&target).expect("read"), b"data");
    }

    #[cfg(unix)]
    #[test]
    fn a_loop_of_links_is_an_error_not_a_hang() {
        let dir = scratch("loop");
        std::os::unix::fs::symlink("b", dir.join("a")).expect("linked");
        std::os::unix::fs::symlink("a", dir.join("b")).expect("linked");
        assert!(replace(&dir.join("a"), b"x").is_err());
    }
}
