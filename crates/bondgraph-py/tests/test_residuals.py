"""Residuals from Python: the CLI's numbers, on every kind of table, and clear errors."""

import csv
import io
import sys

import numpy as np
import pytest

import bondgraph_compiler as bgc

from conftest import BENCH, ROOT, bgc_cli

SCENARIO = ROOT / "scenarios" / "bench_dead_zone.scn"


@pytest.fixture(scope="module")
def bench():
    return bgc.compile(BENCH)


@pytest.fixture(scope="module")
def record(bench):
    """A simulated run of the bench with a dead zone, as a pandas DataFrame."""
    return bench.simulate(SCENARIO)


def read_csv(text):
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], rows[1:]


def test_the_residuals_are_the_clis(bench, record, tmp_path):
    path = tmp_path / "record.csv"
    record.to_csv(path, index=False, float_format="%.17g")
    run = bench.residuals(record, thresholds={"ARR1": 0.5, "ARR2": 0.05})
    header, rows = read_csv(
        bgc_cli("residuals", str(BENCH), str(path), "--threshold", "ARR1=0.5", "--threshold", "ARR2=0.05")
    )
    assert len(rows) == len(run)
    column = {name: k for k, name in enumerate(header)}
    for k in (0, len(rows) // 2, len(rows) - 1):
        assert float(rows[k][column["t"]]) == pytest.approx(run.time[k], abs=1e-9)
        for j, name in enumerate(run.names):
            cell = rows[k][column[name]]
            assert float(cell) == pytest.approx(run.values[k, j], rel=1e-12, abs=1e-12), (k, name)
    alarms = np.array([[r[column[f"alarm_{n}"]] == "1" for n in run.names] for r in rows])
    assert (alarms == run.alarms).all()
    assert [r[column["candidates"]] for r in rows] == list(run.candidates)
    assert [r[column["episode"]] for r in rows] == list(run.episode)
    assert run.alarms.any(), "the dead zone raises alarms"


def test_adaptive_thresholds_are_the_clis_and_fixed_ones_one_row(bench, record, tmp_path):
    path = tmp_path / "record.csv"
    record.to_csv(path, index=False, float_format="%.17g")
    run = bench.residuals(record, thresholds=0.05, adaptive=True)
    header, rows = read_csv(bgc_cli(
            "residuals", str(BENCH), str(path), "--threshold", "ARR1=0.05", "--threshold", "ARR2=0.05", "--adaptive"
        ))
    column = {name: k for k, name in enumerate(header)}
    for j, name in enumerate(run.names):
        cli = np.array([float(r[column[f"threshold_{name}"]]) for r in rows])
        np.testing.assert_allclose(run.thresholds[:, j], cli, rtol=1e-12, atol=1e-15)
        assert np.ptp(cli) > 0, "the bound moves the level"
    assert (np.array([[r[column[f"alarm_{n}"]] == "1" for n in run.names] for r in rows]) == run.alarms).all()
    # Fixed levels: every estimate's row is the same one, not a copy per estimate.
    fixed = bench.residuals(record, thresholds=0.05)
    assert fixed.thresholds.shape == fixed.values.shape and (fixed.thresholds == 0.05).all()
    assert fixed.thresholds.strides[0] == 0


def test_an_overflowing_bound_is_a_missing_threshold_not_inf(bench, record):
    """Signals near the largest double: the adaptive bound and some residuals overflow. They
    are missing (NaN), as the CLI leaves their cells empty, never inf; no alarm is raised there."""
    huge = record.head(3000).copy()
    for name in huge.columns:
        if name != "t":
            huge[name] = huge[name] * 1e306
    run = bench.residuals(huge, thresholds=0.05, adaptive=True)
    assert not np.isinf(run.thresholds).any() and not np.isinf(run.values).any()
    assert np.isnan(run.thresholds).any()
    assert not run.alarms[np.isnan(run.thresholds)].any()


def test_pandas_polars_and_dicts_give_the_same_residuals(bench, record):
    polars = pytest.importorskip("polars")
    levels = {"ARR1": 0.5, "ARR2": 0.05}
    from_pandas = bench.residuals(record, thresholds=levels)
    from_polars = bench.residuals(polars.from_pandas(record), thresholds=levels)
    from_dict = bench.residuals({c: record[c].to_numpy() for c in record.columns}, thresholds=levels)
    for other in (from_polars, from_dict):
        np.testing.assert_array_equal(other.values, from_pandas.values)
        np.testing.assert_array_equal(other.alarms, from_pandas.alarms)


def test_renamed_columns_are_mapped(bench, record):
    renamed = record.rename(columns={"y1": "motor_speed"})
    run = bench.residuals(renamed, columns={"y1": "motor_speed"}, thresholds=1.0)
    np.testing.assert_array_equal(run.values, bench.residuals(record, thresholds=1.0).values)


def test_calibration_keeps_a_healthy_record_quiet(bench):
    healthy = bench.simulate(ROOT / "scenarios" / "paper_section5_healthy.scn")
    # The estimator fixed: the search is the CLI's (tested there and on the pump below).
    run = bench.residuals(healthy, calibrate=healthy, window=51, integration=1000)
    assert not run.alarms.any()
    assert np.isfinite(run.thresholds).all()


def test_the_dataframe_has_the_csvs_columns(bench, record):
    frame = bench.residuals(record, thresholds=1.0).to_pandas()
    names = [a.name for a in bench.arrs]
    assert list(frame.columns) == (
        ["t"] + names + [f"threshold_{n}" for n in names] + [f"alarm_{n}" for n in names]
        + ["candidates", "suspects", "episode"]
    )


# Bad input gets an exception that says what is wrong.


def test_a_missing_column_is_named_with_a_suggestion(bench, record):
    with pytest.raises(bgc.DataError, match=r"no column `y1`.*did you mean `y_1`"):
        bench.residuals(record.rename(columns={"y1": "y_1"}))


def test_a_nan_is_located(bench, record):
    broken = record.copy()
    broken.loc[100, "y2"] = np.nan
    with pytest.raises(bgc.DataError, match=r"row 100, column `y2`: NaN is not a finite number"):
        bench.residuals(broken)


def test_a_column_of_text_is_refused(bench, record):
    broken = record.copy()
    broken["y2"] = broken["y2"].astype(str)
    with pytest.raises(bgc.DataError, match=r"column `y2` holds object values; expected numbers"):
        bench.residuals(broken)


def test_time_must_go_forward_at_one_step(bench, record):
    shuffled = record.copy()
    shuffled.loc[10, "t"] = shuffled.loc[9, "t"]
    with pytest.raises(bgc.DataError, match=r"row 10: time goes from"):
        bench.residuals(shuffled)
    uneven = record.copy()
    uneven.loc[10, "t"] += 1e-4
    with pytest.raises(bgc.DataError, match=r"uniform step"):
        bench.residuals(uneven)


def test_too_few_samples_for_the_window(bench, record):
    with pytest.raises(bgc.DataError, match=r"window of 11"):
        bench.residuals(record.head(5))


def test_bad_thresholds_and_settings_are_refused(bench, record):
    with pytest.raises(KeyError, match=r"ARR9"):
        bench.residuals(record, thresholds={"ARR9": 1.0})
    with pytest.raises(ValueError, match=r"finite number ≥ 0"):
        bench.residuals(record, thresholds=-1.0)
    with pytest.raises(ValueError, match=r"finite number ≥ 0"):
        bench.residuals(record, thresholds=float("inf"))
    with pytest.raises(ValueError, match=r"savitzky-golay"):
        bench.residuals(record, estimator="kalman")
    with pytest.raises(ValueError, match=r"debounce"):
        bench.residuals(record, debounce=0)
    with pytest.raises(ValueError):
        bench.residuals(record, window=10)
    with pytest.raises(TypeError, match=r"dict of arrays"):
        bench.residuals([1, 2, 3])


def test_a_bad_scenario_raises_located_errors(bench):
    with pytest.raises(bgc.ScenarioError) as e:
        bench.simulate("duration 1\nstep 0.001\ninput U0 = nonsense(\n")
    assert e.value.diagnostics[0]["line"] == 3


def test_parquet_from_pandas_and_polars_gives_the_csvs_residuals(bench, record, tmp_path):
    """The CLI on the same samples as CSV, as Parquet from pandas (pyarrow, snappy) and from
    Polars (zstd): byte-identical residual CSVs."""
    pytest.importorskip("pyarrow")
    polars = pytest.importorskip("polars")
    head = record.head(6000)
    head.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    head.to_parquet(tmp_path / "pandas.parquet", index=False)
    polars.from_pandas(head).write_parquet(tmp_path / "polars.parquet", compression="zstd")
    args = ["--threshold", "ARR1=0.5", "--threshold", "ARR2=0.05"]
    from_csv = bgc_cli("residuals", str(BENCH), str(tmp_path / "r.csv"), *args)
    assert len(from_csv.splitlines()) > 5000
    for name in ("pandas.parquet", "polars.parquet"):
        assert bgc_cli("residuals", str(BENCH), str(tmp_path / name), *args) == from_csv, name


def _unwrapped(stderr: str) -> str:
    """A diagnostic's words on one line: its wrapping follows the terminal's width, which a
    test worker's environment sets its own way."""
    return " ".join(stderr.replace("│", " ").split())


def test_mat_files_from_scipy_give_the_csvs_residuals(record, tmp_path):
    """The CLI on the same samples as CSV and as Matlab level-5 files written by scipy, plain
    and zlib-compressed (`-v7`), by `scripts/records/to_mat.py`: byte-identical residual CSVs,
    for `identify` too; a variable the file lacks is named with what it holds."""
    import subprocess

    from conftest import cli_path

    pytest.importorskip("scipy")
    # Long enough for identification's ten batches.
    head = record.head(24000)
    head.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    script = ROOT / "scripts" / "records" / "to_mat.py"
    for name, extra in (("plain.mat", []), ("compressed.mat", ["--compress"])):
        subprocess.run([sys.executable, str(script), str(tmp_path / "r.csv"), str(tmp_path / name),
                        *extra], check=True)
    args = ["--threshold", "ARR1=0.5", "--threshold", "ARR2=0.05"]
    from_csv = bgc_cli("residuals", str(BENCH), str(tmp_path / "r.csv"), *args)
    assert len(from_csv.splitlines()) > 5000
    for name in ("plain.mat", "compressed.mat"):
        assert bgc_cli("residuals", str(BENCH), str(tmp_path / name), *args) == from_csv, name
    fitted = {}
    for name in ("r.csv", "compressed.mat"):
        out = tmp_path / f"{name}.params"
        bgc_cli("identify", str(BENCH), str(tmp_path / name), "--only", "fe", "-o", str(out))
        fitted[name] = [l for l in out.read_text().splitlines() if not l.startswith("#")]
    assert fitted["r.csv"] == fitted["compressed.mat"]
    done = subprocess.run([cli_path(), "residuals", str(BENCH), str(tmp_path / "plain.mat"),
                           "--column", "y1=speed"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 1
    said = _unwrapped(done.stderr)
    assert "no variable `speed`" in said and "`y1`" in said, done.stderr


def test_tdms_files_from_nptdms_give_the_csvs_residuals(record, tmp_path):
    """The CLI on the same samples as CSV and as TDMS written by npTDMS in segments, as a
    logger streams them (`scripts/records/to_tdms.py`): byte-identical residual CSVs; a channel
    the file lacks is named with what it holds."""
    import subprocess

    from conftest import cli_path

    pytest.importorskip("nptdms")
    head = record.head(6000)
    head.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    script = ROOT / "scripts" / "records" / "to_tdms.py"
    for name, rows in (("one.tdms", "10000"), ("streamed.tdms", "700")):
        subprocess.run([sys.executable, str(script), str(tmp_path / "r.csv"), str(tmp_path / name),
                        "--segment", rows], check=True)
    args = ["--threshold", "ARR1=0.5", "--threshold", "ARR2=0.05"]
    from_csv = bgc_cli("residuals", str(BENCH), str(tmp_path / "r.csv"), *args)
    for name in ("one.tdms", "streamed.tdms"):
        assert bgc_cli("residuals", str(BENCH), str(tmp_path / name), *args) == from_csv, name
    done = subprocess.run([cli_path(), "residuals", str(BENCH), str(tmp_path / "one.tdms"),
                           "--time", "time"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 1
    said = _unwrapped(done.stderr)
    assert "no channel `time`" in said and "`record/t`" in said, done.stderr


def test_mdf4_files_from_asammdf_give_the_csvs_residuals(record, tmp_path):
    """The CLI on the same samples as CSV and as ASAM MDF 4 written by asammdf, plain and with
    its data transposed and zipped (`scripts/records/to_mdf.py`): byte-identical residual CSVs,
    the channel group's master channel read as the time."""
    import subprocess

    pytest.importorskip("asammdf")
    head = record.head(6000)
    head.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    script = ROOT / "scripts" / "records" / "to_mdf.py"
    for name, extra in (("plain.mf4", []), ("zipped.mf4", ["--compress"])):
        subprocess.run([sys.executable, str(script), str(tmp_path / "r.csv"), str(tmp_path / name),
                        *extra], check=True)
    args = ["--threshold", "ARR1=0.5", "--threshold", "ARR2=0.05"]
    from_csv = bgc_cli("residuals", str(BENCH), str(tmp_path / "r.csv"), *args)
    for name in ("plain.mf4", "zipped.mf4"):
        assert bgc_cli("residuals", str(BENCH), str(tmp_path / name), *args) == from_csv, name


def test_python_reads_a_loggers_record_from_its_path(bench, record, tmp_path):
    """`model.residuals(path)`: a MAT-file, TDMS, MDF 4, Parquet or CSV record read from its
    path gives the residuals of the same samples as a DataFrame; a column the file lacks is a
    DataError naming it and the file."""
    import subprocess

    pytest.importorskip("scipy")
    pytest.importorskip("nptdms")
    pytest.importorskip("asammdf")
    pytest.importorskip("pyarrow")
    head = record.head(4000)
    head.to_csv(tmp_path / "r.csv", index=False, float_format="%.17g")
    head.to_parquet(tmp_path / "r.parquet", index=False)
    scripts = ROOT / "scripts" / "records"
    for script, name in (("to_mat.py", "r.mat"), ("to_tdms.py", "r.tdms"), ("to_mdf.py", "r.mf4")):
        subprocess.run([sys.executable, str(scripts / script), str(tmp_path / "r.csv"),
                        str(tmp_path / name)], check=True)
    expected = bench.residuals(head)
    for name in ("r.csv", "r.parquet", "r.mat", "r.tdms", "r.mf4"):
        got = bench.residuals(tmp_path / name)
        assert np.array_equal(got.time, expected.time), name
        assert np.array_equal(got.values, expected.values, equal_nan=True), name
    with pytest.raises(bgc.DataError, match=r"r\.mat \(a MAT-file\): no variable `speed`"):
        bench.residuals(str(tmp_path / "r.mat"), columns={"y1": "speed"})


def test_a_damaged_parquet_page_is_refused_where_the_file_has_checksums(record, tmp_path):
    """One flipped bit in a value: with page checksums (pyarrow's `write_page_checksum`) the
    file is refused with what is wrong; without, Parquet has nothing to tell it by, and the
    value is read as written (docs/simulation.md says so)."""
    import subprocess

    from conftest import cli_path

    pytest.importorskip("pyarrow")
    head = record.head(2000)
    value = head["y1"].to_numpy()[1000].tobytes()
    for checksums in (True, False):
        path = tmp_path / f"checksums_{checksums}.parquet"
        head.to_parquet(path, index=False, compression=None, use_dictionary=False,
                        write_page_checksum=checksums)
        raw = bytearray(path.read_bytes())
        at = raw.find(value)
        assert at > 0
        raw[at + 3] ^= 0x10
        path.write_bytes(bytes(raw))
        done = subprocess.run([cli_path(), "residuals", str(BENCH), str(path)],
                              cwd=ROOT, capture_output=True, text=True)
        if checksums:
            assert done.returncode == 1, done.stderr
            assert "checksum" in done.stderr and "Parquet" in done.stderr, done.stderr
        else:
            assert done.returncode == 0, done.stderr


def test_unaligned_and_strided_columns_are_taken(bench, record):
    """Columns that are views into other memory (every other row, a byte off alignment, as
    Arrow buffers moved between processes can be) give the residuals of the same values."""
    expected = bench.residuals(record, thresholds=1.0).values

    def unaligned(values):
        raw = np.zeros(values.size * 8 + 1, dtype=np.uint8)[1:].view(np.float64)
        raw[:] = values
        assert not raw.flags.aligned
        return raw

    data = {c: unaligned(record[c].to_numpy()) for c in record.columns}
    np.testing.assert_array_equal(bench.residuals(data, thresholds=1.0).values, expected)
    doubled = {c: np.repeat(record[c].to_numpy(), 2)[::2] for c in record.columns}
    np.testing.assert_array_equal(bench.residuals(doubled, thresholds=1.0).values, expected)


def test_a_residual_without_threshold_has_a_missing_one_and_no_alarm(bench, record):
    run = bench.residuals(record, thresholds={"ARR2": 0.05})
    assert np.isnan(run.thresholds[:, 0]).all() and not run.alarms[:, 0].any()
    assert (run.thresholds[:, 1] == 0.05).all() and run.alarms[:, 1].any()
    assert run.to_pandas()["threshold_ARR1"].isna().all()


def test_a_million_rows_in_one_call(bench, capsys):
    """A 10^6-row DataFrame in one call: every estimate there, the first ones equal to those
    of its first 10^4 rows alone (the pass carries its state in order). The rate is printed,
    not asserted (bench/residuals.py measures it)."""
    import time

    import pandas as pd

    rows = 1_000_000
    t = np.arange(rows) * 1e-3
    waves = [np.sin(t), np.cos(1.3 * t), np.sin(0.7 * t)]
    frame = pd.DataFrame({"t": t, **dict(zip(bench.signals, waves))})
    start = time.perf_counter()
    run = bench.residuals(frame, thresholds=1.0)
    seconds = time.perf_counter() - start
    assert len(run) == rows - 10 and np.isfinite(run.values).all()
    head = bench.residuals(frame.head(10_000), thresholds=1.0)
    np.testing.assert_array_equal(run.values[: len(head)], head.values)
    with capsys.disabled():
        print(f"\n{rows} rows in {seconds * 1e3:.0f} ms: {rows / seconds / 1e6:.1f} million rows/s")


def test_a_bad_value_is_named_by_the_datas_column(bench, record):
    broken = record.rename(columns={"y1": "motor_speed", "t": "time"})
    broken.loc[7, "motor_speed"] = np.inf
    with pytest.raises(bgc.DataError, match=r"row 7, column `motor_speed`: inf is not a finite number"):
        bench.residuals(broken, time="time", columns={"y1": "motor_speed"})
    broken.loc[3, "time"] = np.nan
    with pytest.raises(bgc.DataError, match=r"row 3, column `time`: NaN is not a finite number"):
        bench.residuals(broken, time="time", columns={"y1": "motor_speed"})


def test_a_kept_calibration_decides_in_python_as_in_the_cli(bench, tmp_path):
    """The file ``--save-calibration`` writes, read by Python: the same residuals, thresholds
    and alarms as ``bgc residuals --calibration`` on the same record; refused for another
    model's text and beside ``calibrate``."""
    healthy, faulty, kept = tmp_path / "healthy.csv", tmp_path / "faulty.csv", tmp_path / "bench.cal"
    bgc_cli("simulate", str(BENCH), str(SCENARIO), "--seed", "7", "--duration", "9.5", "-o", str(healthy))
    bgc_cli("simulate", str(BENCH), str(SCENARIO), "-o", str(faulty))
    bgc_cli(
        "residuals", str(BENCH), str(healthy), "--calibrate", str(healthy),
        "--save-calibration", str(kept), "-o", str(tmp_path / "h.csv"),
    )
    header, rows = read_csv(bgc_cli("residuals", str(BENCH), str(faulty), "--calibration", str(kept)))
    data = {name: np.array(column) for name, column in zip(*_columns_of(faulty))}
    # The CLI decides on a calibration with the bank (the ARRs and the partial copies)
    # unless told otherwise: the file is for those residuals, and says so.
    with pytest.raises(bgc.DataError, match="bank"):
        bench.residuals(data, calibration=kept)
    bank = bgc.compile(BENCH, residuals="bank")
    run = bank.residuals(data, calibration=kept)
    _assert_decides_as_the_cli(header, rows, run)
    assert run.alarms.any(), "the dead zone raises alarms"

    other = bgc.compile(BENCH.read_text() + "\n# another model\n")
    with pytest.raises(bgc.DataError, match="made for another model"):
        other.residuals(data, calibration=kept)
    with pytest.raises(ValueError, match="calibration decides"):
        bench.residuals(data, calibration=kept, calibrate=data)


def _assert_decides_as_the_cli(header, rows, run):
    """The CLI's residual CSV (`header`, `rows`) and a Python run agree: the same estimates,
    residuals and thresholds to rounding, the same alarms and episodes exactly."""
    assert len(rows) == len(run)
    column = {name: k for k, name in enumerate(header)}
    times = np.array([float(r[column["t"]]) for r in rows])
    np.testing.assert_allclose(times, run.time, rtol=0, atol=1e-9)
    for k, row in enumerate(rows):
        for j, name in enumerate(run.names):
            assert float(row[column[name]]) == pytest.approx(run.values[k, j], rel=1e-12, abs=1e-15)
            # An empty cell: no threshold there (a singular sample), NaN in Python.
            level = float(row[column[f"threshold_{name}"]] or "nan")
            assert level == pytest.approx(run.thresholds[k, j], rel=1e-12, nan_ok=True), (k, name)
    alarms = np.array([[r[column[f"alarm_{n}"]] == "1" for n in run.names] for r in rows])
    assert (alarms == run.alarms).all()
    assert [r[column["episode"]] for r in rows] == list(run.episode)


def _columns_of(path):
    """A CSV's header and its columns as floats."""
    with open(path) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    return header, [[float(r[k]) for r in rows[1:]] for k in range(len(header))]


PUMP = ROOT / "models" / "centrifugal_pump.bg"
PUMP_SCENARIO = ROOT / "scenarios" / "pump_healthy.scn"


def test_calibration_in_python_decides_as_the_cli_on_a_pump_from_rest(tmp_path):
    """``calibrate=`` runs the CLI's calibration (one implementation): on a pump started from
    rest, Python and ``bgc residuals --calibrate`` leave the same start-up out and give the
    same thresholds, residuals and alarms; the clog of the drain alarms and is named."""
    healthy, clogged = tmp_path / "healthy.csv", tmp_path / "clogged.csv"
    bgc_cli("simulate", str(PUMP), str(PUMP_SCENARIO), "--duration", "12", "-o", str(healthy))
    bgc_cli(
        "simulate", str(PUMP), str(PUMP_SCENARIO), "--duration", "12", "--seed", "2",
        "-e", "fault c = 0.6*c at 8", "-o", str(clogged),
    )
    # The decisions are compared, not the sizes (test_identify.py compares those); the
    # CLI's residuals named as the model's here are (it decides with the bank by default).
    header, rows = read_csv(bgc_cli(
        "residuals", str(PUMP), str(clogged), "--residuals", "per-sensor", "--calibrate",
        str(healthy), "--no-size",
    ))
    pump = bgc.compile(PUMP)
    columns = lambda path: {n: np.array(c) for n, c in zip(*_columns_of(path))}
    run = pump.residuals(columns(clogged), calibrate=columns(healthy), size_span=None)
    assert any("starts unsettled" in n for n in run.notes), run.notes
    _assert_decides_as_the_cli(header, rows, run)
    assert run.alarms[:, 2].any() and not run.alarms[run.time < 7.7].any()
    assert run.episode[-1] == "tank drain"
    # A CUSUM beside each threshold decides alike too.
    header, rows = read_csv(bgc_cli(
        "residuals", str(PUMP), str(clogged), "--residuals", "per-sensor", "--calibrate", str(healthy),
        "--keep-model", "--cusum", "0.7", "--no-size",
    ))
    run = pump.residuals(
        columns(clogged), calibrate=columns(healthy), keep_model=True, cusum=0.7, size_span=None,
    )
    assert any("a CUSUM beside each threshold" in n for n in run.notes), run.notes
    _assert_decides_as_the_cli(header, rows, run)
