//! `bgc completions`: a shell's completion script for bgc.

use crate::io;
use crate::report::Failure;

/// Writes the completion script of `command` (bgc's own) for `shell`.
pub(crate) fn run(shell: clap_complete::Shell, mut command: clap::Command) -> Result<(), Failure> {
    let mut out = Vec::new();
    clap_complete::generate(shell, &mut command, "bgc", &mut out);
    io::write(None, &String::from_utf8_lossy(&out))
}
