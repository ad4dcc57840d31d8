"""Shared by the package's tests: where the repository's models are, and the CLI to compare
with (``$BGC``, else the workspace's debug build, built if missing)."""

from __future__ import annotations

import os
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[3]
BENCH = ROOT / "models" / "backlash_bench.bg"
_CLI = []


def cli_path() -> str:
    if not _CLI:
        given = os.environ.get("BGC")
        if given:
            _CLI.append(given)
        else:
            built = ROOT / "target" / "debug" / "bgc"
            if not built.exists():
                subprocess.run(["cargo", "build", "-q", "-p", "bgc"], cwd=ROOT, check=True)
            _CLI.append(str(built))
    return _CLI[0]


def bgc_cli(*args: str, env: dict | None = None) -> str:
    """What the CLI prints on standard output (with ``env`` added to its environment); a
    failure fails the test."""
    full = None if env is None else {**os.environ, **env}
    done = subprocess.run([cli_path(), *args], cwd=ROOT, capture_output=True, text=True, env=full)
    assert done.returncode == 0, done.stderr
    return done.stdout
