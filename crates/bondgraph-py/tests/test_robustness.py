"""Nothing a user passes crashes the interpreter: mutated models, scenarios and records
raise the package's exceptions (or work), never a Rust panic."""

import random

import numpy as np
import pytest

import bondgraph_compiler as bgc

from conftest import BENCH, ROOT

SCENARIO = (ROOT / "scenarios" / "bench_dead_zone.scn").read_text(encoding="utf-8")
ALPHABET = "abcxyz019_ .,;:=+-*/^()[]{}<>#\"'\n\t->|\u00e9"


def mutants(text, count, seed):
    """`text` with a few characters deleted, replaced or inserted, `count` times."""
    rng = random.Random(seed)
    for _ in range(count):
        chars = list(text)
        for _ in range(rng.randint(1, 4)):
            at = rng.randrange(len(chars) + 1)
            what = rng.random()
            if what < 0.34 and at < len(chars):
                del chars[at]
            elif what < 0.67 and at < len(chars):
                chars[at] = rng.choice(ALPHABET)
            else:
                chars.insert(at, rng.choice(ALPHABET))
        yield "".join(chars)


def test_mutated_models_raise_located_model_errors_or_compile():
    text = BENCH.read_text(encoding="utf-8")
    failed = 0
    for mutant in mutants(text, 80, seed=1):
        try:
            bgc.compile(mutant)
        except bgc.ModelError as e:
            failed += 1
            assert e.diagnostics and all(d["line"] >= 1 and d["column"] >= 1 for d in e.diagnostics)
    assert failed > 10, "the mutants reach the errors"


def test_mutated_scenarios_raise_scenario_errors_or_run():
    model = bgc.compile(BENCH)
    short = SCENARIO.replace("duration 25", "duration 0.5")
    for mutant in mutants(short, 40, seed=2):
        try:
            model.simulate(mutant)
        except (bgc.ScenarioError, bgc.SimulationError):
            pass


def test_random_records_raise_data_errors_or_run():
    model = bgc.compile(BENCH)
    rng = np.random.default_rng(3)
    for k in range(60):
        n = int(rng.integers(0, 40))
        data = {name: rng.normal(size=n) for name in ["t", *model.signals]}
        if k % 3 == 0:
            data["t"] = np.arange(n) * 1e-3
        if k % 5 == 0 and n:
            data[model.signals[0]][rng.integers(0, n)] = np.inf
        try:
            model.residuals(data, thresholds=1.0, window=int(rng.choice([3, 5, 11, 12])))
        except (bgc.DataError, ValueError):
            pass


def test_an_input_with_no_value_is_located_at_its_scenario_line():
    """`log(t)` at t = 0: the run stops with the scenario's line and column, as the CLI says."""
    model = bgc.compile(ROOT / "models" / "dc_motor.bg")
    with pytest.raises(bgc.SimulationError) as e:
        model.simulate("duration 1\n# the supply\ninput U0 = 12 + log(t)\n")
    assert "<scenario>:3:7" in str(e.value) and "`U0` is not a finite number" in str(e.value)
    assert e.value.diagnostics[0]["line"] == 3
