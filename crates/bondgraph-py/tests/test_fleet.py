"""The fleet example (docs/fleet.py): a partitioned Parquet dataset through Dask on a local
cluster gives, machine by machine, what one pass over each machine's record gives."""

import importlib.util
import sys

import numpy as np
import pytest

from conftest import ROOT

pytest.importorskip("dask.dataframe")
distributed = pytest.importorskip("distributed")
pytest.importorskip("pyarrow")


def load_fleet():
    spec = importlib.util.spec_from_file_location("fleet", ROOT / "docs" / "fleet.py")
    fleet = importlib.util.module_from_spec(spec)
    sys.modules["fleet"] = fleet
    spec.loader.exec_module(fleet)
    return fleet


def test_a_fleet_through_dask_finds_its_faulty_machine(tmp_path):
    fleet = load_fleet()
    text = fleet.MODEL.read_text(encoding="utf-8")
    faulty = fleet.make_fleet(tmp_path / "fleet", machines=6, rows=20_000, text=text)
    thresholds = fleet.healthy_thresholds(text)
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    dataset = str(tmp_path / "fleet")
    with cluster, distributed.Client(cluster) as client:
        fleet.prepare(client)
        residuals = client.compute(fleet.fleet_residuals(dataset, text, thresholds)).result()
        table = client.compute(fleet.fleet_summary(dataset, text, thresholds)).result().sort_index()
        # Machines spread over partitions are gathered first: the same answer.
        shuffled = client.compute(fleet.fleet_summary(dataset, text, thresholds, file_per_machine=False))
        shuffled = shuffled.result().sort_index()
    assert table.equals(fleet.summary(residuals))
    assert shuffled.equals(table)
    assert sorted(table.index) == list(range(6))
    assert [m for m in table.index if table.loc[m, "alarm"]] == [m for m, f in faulty.items() if f]
    assert table.loc[3, "first_alarm"] == pytest.approx(10.0, abs=0.5)
    assert "link" in table.loc[3, "episode"].split()
    # Machine by machine, what one pass over its record in time order gives.
    import pandas as pd

    record = pd.read_parquet(tmp_path / "fleet" / "machine=3" / "part.parquet")
    alone = fleet.compiled(text).residuals(record, thresholds=thresholds)
    mine = residuals[residuals["machine"] == 3].sort_values("t")
    np.testing.assert_array_equal(mine["ARR2"].to_numpy(), alone["ARR2"])
    np.testing.assert_array_equal(mine["alarm_ARR2"].to_numpy(), alone.alarms[:, 1])
