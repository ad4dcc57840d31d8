"""The README's Python example, run as written: its monitored record raises no alarm before
its fault, and its fault is seen and named."""

from __future__ import annotations

import os
import re

import numpy as np

from conftest import ROOT

# The bench's dead zone triples at this instant in `scenarios/bench_dead_zone.scn`.
FAULT_AT = 10.0


def _python_example() -> str:
    """The README's first ``python`` block that compiles a model."""
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    return next(b for b in blocks if "bgc.compile(" in b and "residuals(" in b)


def test_the_readmes_python_example_raises_no_alarm_before_its_fault():
    code = _python_example()
    scope: dict = {}
    here = os.getcwd()
    os.chdir(ROOT)  # its paths are the repository's
    try:
        exec(compile(code, "README.md", "exec"), scope)
    finally:
        os.chdir(here)
    run = scope["run"]
    # An estimate reads half its window ahead of its instant: at most 501 samples of 1 ms.
    lookahead = 0.251
    early = run.alarms[run.time < FAULT_AT - lookahead].any(axis=1)
    assert not early.any(), f"alarms from {run.time[run.time < FAULT_AT - lookahead][early][0]} s"
    late = run.alarms[run.time > FAULT_AT + 1.0].any(axis=1)
    assert late.any(), "the dead zone is never seen"
    assert any("link" in c for c in np.asarray(run.episode)[run.time > FAULT_AT + 1.0])


def test_the_readmes_example_stays_within_what_calibration_covered():
    """Its healthy record drives the bench as the monitored one does: the per-estimate
    `beyond` column (a calibration's) flags no signal before the fault, and is a column of
    the frame as of the CLI's CSV."""
    code = _python_example()
    scope: dict = {}
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(code, "README.md", "exec"), scope)
    finally:
        os.chdir(here)
    run = scope["run"]
    beyond = run.beyond
    assert beyond is not None and len(beyond) == len(run.time)
    before = beyond[run.time < FAULT_AT]
    assert all(b == "" for b in before), sorted(set(before))
    columns = run.to_dict()
    assert "beyond" in columns
    # The bench's ARRs are integrated: each has a hold beside its onset test, as the CLI's
    # CSV has, and an alarm wherever its hold is over its threshold; the dead zone's (ARR2,
    # from the start) is, after the fault.
    for name in run.names:
        hold, level = columns[f"hold_{name}"], columns[f"hold_threshold_{name}"]
        over = np.abs(hold) > level
        assert columns[f"alarm_{name}"][over].all(), name
    over = np.abs(columns["hold_ARR2"]) > columns["hold_threshold_ARR2"]
    assert over[run.time > FAULT_AT + 1.0].any()
