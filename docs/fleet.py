"""Residuals and alarms for a fleet: many machines' records in a partitioned Parquet dataset,
computed with Dask (one machine per group, each machine's samples in time order in one
pass, so the estimators' and integrals' state runs on from one sample to the next).

    python docs/fleet.py --machines 100 --rows 100000 --workers 1 2

writes a dataset of simulated backlash benches (a tenth of them with a dead zone that triples
half-way), then reports, per number of workers, the rows per second of the whole
computation, and which machines are in alarm and what the alarms point to.

The same code runs on a multi-machine Dask cluster: start a scheduler (`dask scheduler`)
and workers on each machine (`dask worker tcp://SCHEDULER:8786`), give `--scheduler
tcp://SCHEDULER:8786` instead of `--workers`, and put the dataset where every worker reads
it (a shared file system, or object storage: `s3://bucket/fleet/`, with s3fs installed).
Each worker needs the package (`pip install ./crates/bondgraph-py`) and the model file at
the same path, or pass the model's text: `fleet_residuals` sends the text, not a path.
"""

from __future__ import annotations

import argparse
import functools
import pathlib
import time
from typing import Dict, List, Optional

import numpy as np
import pandas as pd

import bondgraph_compiler as bgc

ROOT = pathlib.Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "backlash_bench.bg"

#: How every machine is driven; each gets its own noise, a tenth a fault.
DRIVE = """
step 0.001
input U0 = 6 + 12*sin(0.5*t)
noise y1 1e-4
noise y2 1e-4
"""


@functools.lru_cache(maxsize=8)
def compiled(text: str) -> bgc.Model:
    """The model of `text`, compiled once per worker process."""
    return bgc.compile(text)


def make_fleet(root: pathlib.Path, machines: int, rows: int, text: str) -> Dict[int, bool]:
    """Writes `machines` simulated records of `rows` samples as `root/machine=K/part.parquet`
    (hive partitioning); returns which machines have the fault."""
    model = compiled(text)
    duration = (rows - 1) * 1e-3
    faulty = {}
    for k in range(machines):
        faulty[k] = k % 10 == 3
        scenario = DRIVE + f"duration {duration}\nseed {k + 1}\n"
        if faulty[k]:
            scenario += f"fault j0 = 3*j0 at {duration / 2}\n"
        record = model.simulate(scenario)[["t", *model.signals]]
        folder = root / f"machine={k}"
        folder.mkdir(parents=True, exist_ok=True)
        record.to_parquet(folder / "part.parquet", index=False)
    return faulty


def healthy_thresholds(text: str, rows: int = 20_000) -> Dict[str, float]:
    """Thresholds calibrated on a healthy machine of the fleet's kind, as the CLI calibrates
    them, for the estimator every machine is evaluated with (`machine_residuals`: the
    default fits over 11 samples, integrals over 250) and the model's own values: a level
    holds only for the residuals it was set on, so calibration is not left to choose
    those here (a calibration file keeps every choice: ``calibration=``)."""
    model = compiled(text)
    healthy = model.simulate(DRIVE + f"duration {(rows - 1) * 1e-3}\nseed 999\n")
    run = model.residuals(healthy, calibrate=healthy, window=11, integration=250, keep_model=True)
    return {name: float(run.thresholds[0, k]) for k, name in enumerate(run.names)}


def machine_residuals(record: pd.DataFrame, text: str, thresholds: Dict[str, float]) -> pd.DataFrame:
    """One machine's residuals, alarms and candidates, its samples taken in time order."""
    model = compiled(text)
    record = record.sort_values("t")
    # The frame is what the fleet keeps: no fault sizes (they cost a fit per candidate).
    run = model.residuals(record, thresholds=thresholds, size_span=None)
    out = run.to_pandas()
    out.insert(0, "machine", record["machine"].iloc[0])
    return out


def _meta(text: str) -> pd.DataFrame:
    names = [a.name for a in compiled(text).arrs]
    columns: Dict[str, object] = {"machine": pd.Series(dtype="int64"), "t": pd.Series(dtype="float64")}
    for n in names:
        columns[n] = pd.Series(dtype="float64")
    for n in names:
        columns[f"threshold_{n}"] = pd.Series(dtype="float64")
    for n in names:
        columns[f"alarm_{n}"] = pd.Series(dtype="bool")
    for c in ("candidates", "suspects", "episode"):
        columns[c] = pd.Series(dtype="category")
    return pd.DataFrame(columns)


def _partition(part: pd.DataFrame, text: str, thresholds: Dict[str, float]) -> pd.DataFrame:
    """Every machine of a partition, each in one pass (a partition holds whole machines)."""
    if part.empty:
        return _meta(text)
    part = part.reset_index()
    frames = [machine_residuals(g, text, thresholds) for _, g in part.groupby("machine", sort=True)]
    if len(frames) == 1:
        return frames[0]
    # Categories differ between machines: give the partition one set.
    union = {
        c: pd.api.types.union_categoricals([f[c] for f in frames]).categories
        for c in ("candidates", "suspects", "episode")
    }
    for f in frames:
        for c, categories in union.items():
            f[c] = f[c].cat.set_categories(categories)
    return pd.concat(frames, ignore_index=True)


def fleet_residuals(dataset: str, text: str, thresholds: Dict[str, float], file_per_machine: bool = True):
    """The residuals of every machine of the dataset, as a lazy Dask DataFrame, each
    machine's rows run in one pass in time order.

    With `file_per_machine` (the layout `make_fleet` writes: `machine=K/part.parquet`), each
    file is read whole as one partition and nothing moves between workers. Otherwise (a
    machine's record spread over several files, e.g. a file a day), the rows are first
    shuffled so that each machine's rows share one partition."""
    import dask.dataframe as dd

    if file_per_machine:
        records = dd.read_parquet(dataset, split_row_groups=False)
        records["machine"] = records["machine"].astype("int64")
        by_machine = records
    else:
        records = dd.read_parquet(dataset)
        records["machine"] = records["machine"].astype("int64")
        by_machine = records.set_index("machine", sorted=False)
    return by_machine.map_partitions(_partition, text, thresholds, meta=_meta(text))


def fleet_summary(dataset: str, text: str, thresholds: Dict[str, float], file_per_machine: bool = True):
    """`summary` of every machine, computed where its residuals are (only the summary
    travels back), as a lazy Dask DataFrame."""
    residuals = fleet_residuals(dataset, text, thresholds, file_per_machine)
    meta = pd.DataFrame(
        {
            "estimates": pd.Series(dtype="int64"),
            "alarm": pd.Series(dtype="bool"),
            "first_alarm": pd.Series(dtype="float64"),
            "episode": pd.Series(dtype="object"),
        },
        index=pd.Index([], dtype="int64", name="machine"),
    )
    return residuals.map_partitions(summary, meta=meta)


def summary(residuals: pd.DataFrame) -> pd.DataFrame:
    """Per machine: estimates, whether an alarm was raised, when first (NaN if never), and
    what the whole episode points to."""
    alarm_columns = [c for c in residuals.columns if c.startswith("alarm_")]
    rows = []
    for machine, g in residuals.groupby("machine", sort=True):
        on = g[alarm_columns].any(axis=1).to_numpy()
        first = float(g["t"].to_numpy()[np.argmax(on)]) if on.any() else float("nan")
        rows.append(
            {
                "machine": machine,
                "estimates": len(g),
                "alarm": bool(on.any()),
                "first_alarm": first,
                "episode": str(g["episode"].iloc[-1]),
            }
        )
    if not rows:
        return pd.DataFrame(
            {"machine": [], "estimates": [], "alarm": [], "first_alarm": [], "episode": []}
        ).astype({"machine": "int64", "estimates": "int64", "alarm": "bool", "first_alarm": "float64"}).set_index(
            "machine"
        )
    return pd.DataFrame(rows).set_index("machine")


def prepare(client) -> None:
    """Sends this module to every worker of `client`'s cluster: the tasks name its functions,
    which a worker on another machine (or a fresh process) imports from there."""
    client.upload_file(__file__)


def run(dataset: str, text: str, thresholds: Dict[str, float], client) -> "tuple[pd.DataFrame, float]":
    """The fleet's summary and the seconds the computation took on `client`'s cluster."""
    prepare(client)
    start = time.perf_counter()
    table = client.compute(fleet_summary(dataset, text, thresholds)).result()
    seconds = time.perf_counter() - start
    return table.sort_index(), seconds


def main(argv: Optional[List[str]] = None) -> None:
    from distributed import Client, LocalCluster

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--machines", type=int, default=100)
    p.add_argument("--rows", type=int, default=100_000)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--scheduler", help="a running Dask scheduler's address, instead of a local cluster")
    p.add_argument("--dataset", type=pathlib.Path, default=pathlib.Path("fleet_dataset"))
    args = p.parse_args(argv)
    text = MODEL.read_text(encoding="utf-8")
    if not args.dataset.exists():
        make_fleet(args.dataset, args.machines, args.rows, text)
    thresholds = healthy_thresholds(text)
    total = args.machines * args.rows
    clusters = [(f"scheduler {args.scheduler}", lambda: Client(args.scheduler))] if args.scheduler else [
        (f"{w} worker(s)", functools.partial(lambda w: Client(LocalCluster(n_workers=w, threads_per_worker=1)), w))
        for w in args.workers
    ]
    for label, connect in clusters:
        with connect() as client:
            table, seconds = run(str(args.dataset), text, thresholds, client)
        print(f"{label}: {total} rows in {seconds:.1f} s, {total / seconds / 1e6:.2f} million rows/s")
    print(table[table["alarm"]].to_string())


if __name__ == "__main__":
    main()
