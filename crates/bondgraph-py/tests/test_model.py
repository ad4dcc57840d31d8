"""The package against the CLI: the same model gives the same ARRs, FSM and residuals."""

import json
import pathlib
import subprocess

import numpy as np
import pytest

import bondgraph_compiler as bgc

from conftest import BENCH, ROOT, bgc_cli


def test_the_bench_compiles_to_the_clis_json():
    model = bgc.compile(BENCH)
    cli = json.loads(bgc_cli(str(BENCH), "--emit", "json"))
    assert model.to_dict() == cli
    assert [a.name for a in model.arrs] == [a["name"] for a in cli["arrs"]]
    assert model.arrs[0].text == cli["arrs"][0]["expr"]
    assert model.parameters["Je"] == cli["parameters"]["Je"]
    assert model.detectors == [s["name"] for s in cli["sensors"]]


def test_text_and_path_give_the_same_model():
    text = BENCH.read_text(encoding="utf-8")
    assert bgc.compile(text).to_dict() == bgc.compile(str(BENCH)).to_dict()
    assert bgc.compile(pathlib.Path(BENCH)).latex() == bgc_cli(str(BENCH), "--emit", "latex")


def test_every_emitter_writes_what_the_cli_writes():
    model = bgc.compile(BENCH)
    assert model.text() == bgc_cli(str(BENCH))
    # The model holds its ARRs, so its drawing fills components by fault class, as the
    # CLI's does when it derives them.
    best = bgc.compile(BENCH, residuals="best")
    assert best.dot() == bgc_cli(str(BENCH), "--emit", "dot", "--residuals", "best")
    assert model.rust() == bgc_cli(str(BENCH), "--emit", "rust")


def test_the_fsm_is_a_dataframe_with_a_column_per_arr():
    model = bgc.compile(BENCH)
    fsm = model.fsm
    cli = json.loads(bgc_cli(str(BENCH), "--emit", "json"))
    for row in cli["fsm"]["rows"]:
        got = [int(fsm.loc[row["component"], name]) for name in cli["fsm"]["residuals"]]
        assert got == row["signature"], row["component"]
    assert list(fsm.columns[-2:]) == ["Db", "Ib"]
    assert model.fault_classes == cli["isolability"]["selected"]["classes"]


def test_an_arr_is_a_sympy_expression_that_vanishes_on_the_models_trajectories():
    sympy = pytest.importorskip("sympy")
    model = bgc.compile(ROOT / "models" / "dc_motor.bg")
    arr = model.arrs[0]  # the armature: U0 = Re i + L di/dt + ke y1
    assert arr.text == "U0 - Re * i - L * der(i) - ke * y1"
    t = sympy.Symbol("t", real=True)
    p = {name: sympy.Symbol(name, real=True) for name in model.parameters}
    current, speed = sympy.sin(t), sympy.cos(2 * t)
    voltage = p["Re"] * current + p["L"] * sympy.diff(current, t) + p["ke"] * speed
    signals = {"i": current, "y1": speed, "U0": voltage}
    e = arr.sympy().subs({sympy.Function(s, real=True)(t): v for s, v in signals.items()})
    assert sympy.simplify(e.doit()) == 0
    # A voltage off by a bit of current does not vanish: the derivative is really one.
    wrong = arr.sympy().subs({sympy.Function(s, real=True)(t): v for s, v in {**signals, "U0": voltage + current}.items()})
    assert sympy.simplify(wrong.doit()) != 0


def test_a_fraction_in_a_law_reaches_sympy_exactly():
    """A law with the exponent 1/3, inverted and differentiated: the ARR's text and its sympy
    form keep -2/3 and 1/3, not the doubles that an exact check finds wrong at 1e-16."""
    sympy = pytest.importorskip("sympy")
    model = bgc.compile(
        "model rational\n"
        'param a = 2 "area"\n'
        'param pa = 1e5 "pre-charge"\n'
        'param c = 0.01 "drain"\n'
        'input U0 "flow"\n'
        'Sf pump = U0 "pump"\n'
        'C acc : q = a*(e/pa)^(1/3) "accumulator"\n'
        'R out : f = c*e^(2/3)/3 "drain"\n'
        'De p on j "pressure"\n'
        "pump -> 0:j -> acc, out\n"
    )
    text = model.arrs[0].text
    assert "(-2/3)" in text and "1/3" in text, text
    assert "0.333" not in text and "0.666" not in text, text
    e = model.arrs[0].sympy()
    assert not e.atoms(sympy.Float), e
    rationals = e.doit().atoms(sympy.Rational)
    assert sympy.Rational(-2, 3) in rationals and sympy.Rational(2, 3) in rationals, rationals


def test_a_notebook_shows_the_arrs_and_the_fsm():
    model = bgc.compile(BENCH)
    latex = model._repr_latex_()
    assert latex.startswith("$$\\begin{align") and latex.endswith("$$")
    html = model._repr_html_()
    assert "<table>" in html and all(a.name in html for a in model.arrs)


def test_a_model_with_errors_raises_every_error_located():
    text = "model m\nelement R1 : R r\nbond 1: R1 -> nowhere\n"
    with pytest.raises(bgc.ModelError) as e:
        bgc.compile(text)
    assert "<model>:" in str(e.value)
    assert e.value.diagnostics, "each error as a dict"
    first = e.value.diagnostics[0]
    assert {"file", "line", "column", "code", "message"} <= set(first)
    assert first["line"] >= 1 and first["column"] >= 1


def test_a_syntax_error_names_its_line_and_column():
    with pytest.raises(bgc.ModelError) as e:
        bgc.compile("model m\nparam R = \n")
    d = e.value.diagnostics[0]
    assert (d["file"], d["line"]) == ("<model>", 2)
    assert f"<model>:2:{d['column']}" in str(e.value)


def test_a_missing_file_is_a_file_error_not_a_model():
    with pytest.raises(FileNotFoundError):
        bgc.compile("no/such/model.bg")


def test_bad_options_raise_value_errors():
    with pytest.raises(ValueError, match="per-sensor"):
        bgc.compile(BENCH, residuals="some")
    with pytest.raises(ValueError, match="lowest"):
        bgc.compile(BENCH, realise="sideways")
    with pytest.raises(TypeError):
        bgc.compile(42)


def test_sensors_proposes_what_the_cli_proposes():
    model = bgc.compile(BENCH)
    answer = model.sensors(goal="isolable")
    cli = bgc_cli("sensors", str(BENCH))
    assert not answer["reached"]
    assert answer["proposals"][0]["detectors"] == [("Df", "elec")]
    assert "Df on elec" in cli, cli
    # The structural classes now: every component in one class, or undetectable.
    now = [c for k in answer["now"]["classes"] for c in k] + answer["now"]["undetectable"]
    assert sorted(now) == sorted(model.fsm.index)
    assert bgc.compile(ROOT / "models" / "three_tank.bg").sensors()["reached"]
    with pytest.raises(ValueError, match=r"`Rn` is not a component of the model \(did you mean `Rm`\?\)"):
        model.sensors(["Rn"])
    with pytest.raises(ValueError, match=r"isolable"):
        model.sensors(goal="cheap")


def test_verify_gives_the_clis_verdicts():
    model = bgc.compile(ROOT / "models" / "dc_motor.bg")
    checked = model.verify()
    assert checked.passed
    assert [a[0] for a in checked.arrs] == [a.name for a in model.arrs]
    assert checked.entries, "every FSM entry of a component that can be faulted"
    for component, arr, marked, worst, ok in checked.entries:
        assert marked == bool(model.fsm.loc[component, arr]), (component, arr)
        assert ok and worst >= 0.0
    arrs, entries = checked.to_pandas()
    assert list(arrs.columns) == ["arr", "worst", "pass"] and len(entries) == len(checked.entries)
    cli = bgc_cli("verify", str(ROOT / "models" / "dc_motor.bg"))
    assert "FAIL" not in cli
    # The CLI's validation, in its words: a scale of 0 or 1e308 verifies nothing, and a
    # billion runs once aborted the interpreter.
    with pytest.raises(ValueError, match=r"state scale must be a number in"):
        model.verify(state_scale=0.0)
    with pytest.raises(ValueError, match=r"input scale must be a number in"):
        model.verify(input_scale=1e308)
    with pytest.raises(ValueError, match=r"runs must be 1 to 1000"):
        model.verify(runs=10**9)
    # The DC motor switches nowhere; the two-mass drive's dry friction does, and its
    # integrated relations are taken through the load's reversals without a jump.
    assert checked.crossings == 0 and checked.jumps == {}
    drive = bgc.compile(ROOT / "models" / "two_mass_friction.bg").verify()
    assert drive.passed and drive.crossings > 0
    assert set(drive.jumps) == {"ARR1", "ARR2"} and max(drive.jumps.values()) < 1e-12


def test_a_model_pickles_as_its_text_and_compiles_again():
    import pickle

    model = bgc.compile(BENCH, residuals="best")
    again = pickle.loads(pickle.dumps(model))
    assert again.to_dict() == model.to_dict()
    assert again.diagnostics == model.diagnostics
    assert len(pickle.dumps(model)) < 2 * len(BENCH.read_text(encoding="utf-8")) + 200
