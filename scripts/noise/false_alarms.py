#!/usr/bin/env python3
"""False alarms against the stated rate: thresholds calibrated on one 200-s healthy record of
the reference bench for a stated rate (`--false-alarm-rate`), then N healthy records of other
noise seeds, 3,000 s each, monitored with the kept calibration; the false-alarm episodes
counted (a run of samples with some alarm, however long) against what the stated rate
predicts.

Outside CI (tens of minutes). Records simulated by scipy (scripts/identify/bench_plant.py,
not bgc), from rest, σ = 1e-4 rad/s on both encoders, 1 kHz; the plant's parameters drawn
within ±3 % of the model's (`--draw`, 0: the model's own). The calibration record is the
first 200 s of the trajectory with noise seed 1; every monitored record is the same 3,000-s
trajectory with noise seeds 100, 101, ... (the open-loop inputs decide it; in the closed
loop, bench_plant.py's PI controller reads the plant, not the noisy encoders). Inputs: the
open-loop square and sine, and the closed loop (`closed`). Records go to
Parquet (pyarrow), residuals to CSV, read back with pyarrow.

What a rate predicts: a calibration states the probability p that a healthy record as long
as the calibration's crosses a threshold (its `crossing` line); a 3,000-s record is 15 such
records, so N records predict about 15 N p of its 200-s spans with a crossing (the `spans` column),
and about as many episodes where a crossing is one run of alarm samples (more where it
flickers about its threshold: each run counts as an episode). Near-misses: each record's
largest |r|/threshold over every test, and the probability that a record crosses from a
Gumbel law fitted to those maxima (L-moments), beside the stated one for a record that long.

Usage: false_alarms.py [--bgc target/release/bgc] [--records 20] [--seconds 3000]
                       [--inputs square sine closed] [--rates 0 1/h 4/h] [--draw 7] [--counts 0]
                       [--where] [--residuals per-sensor|bank|partial]
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "identify"))
import bench_plant  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(HERE))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")
CALIBRATION_SECONDS = 200.0
SIGMA = 1e-4


def write(path, t, U0, y1, y2):
    pq.write_table(pa.table({"t": t, "U0": U0, "y1": y1, "y2": y2}), path)


def noisy(clean, seed, rows, counts=0):
    """The clean record's first `rows` samples with Gaussian noise of SIGMA on both speeds,
    or, with `counts`, both speeds as encoders of that many counts per revolution read them
    (differences of counts, from a first count drawn by `seed`)."""
    t, U0, we, ws = (c[:rows] for c in clean)
    rng = np.random.default_rng(seed)
    if counts:
        step = t[1] - t[0]
        return (t, U0, bench_plant.counted(we, step, counts, rng),
                bench_plant.counted(ws, step, counts, rng))
    return t, U0, we + SIGMA * rng.standard_normal(rows), ws + SIGMA * rng.standard_normal(rows)


def episodes(path):
    """The runs of samples with some alarm in a residual CSV, the calibration-long spans
    with any, and the samples in alarm."""
    table = pacsv.read_csv(path)
    alarms = [c for c in table.column_names if c.startswith("alarm_")]
    on = np.zeros(table.num_rows, dtype=bool)
    for c in alarms:
        on |= table[c].to_numpy() == 1
    rising = np.count_nonzero(on[1:] & ~on[:-1]) + int(on[0]) if on.size else 0
    t = table["t"].to_numpy()
    spans = np.unique(np.floor(t[on] / CALIBRATION_SECONDS)).size
    return rising, spans, int(on.sum())


def nearest(path):
    """The record's largest |r|/threshold over every test (a held residual's onset test and
    hold): how near it came to an alarm; with the test and the instant it came nearest."""
    table = pacsv.read_csv(path)
    names = [c[6:] for c in table.column_names if c.startswith("alarm_")]
    time = table["t"].to_numpy()
    worst = (0.0, "", float("nan"))
    for name in names:
        pairs = [(name, f"threshold_{name}")]
        if f"hold_{name}" in table.column_names:
            pairs.append((f"hold_{name}", f"hold_threshold_{name}"))
        for value, level in pairs:
            r = np.abs(table[value].to_numpy(zero_copy_only=False).astype(float))
            t = table[level].to_numpy(zero_copy_only=False).astype(float)
            ratio = np.where(np.isfinite(r / t), r / t, -np.inf)
            k = int(np.argmax(ratio))
            if ratio[k] > worst[0]:
                worst = (float(ratio[k]), value, float(time[k]))
    return worst


def gumbel_crossing(maxima):
    """The probability that a record's maximum passes 1 (its threshold), from a Gumbel law
    fitted to the records' maxima by L-moments."""
    m = np.sort(np.asarray(maxima))
    n = len(m)
    if n < 3:
        return float("nan")
    l1 = m.mean()
    b1 = np.sum(np.arange(n) / (n - 1) * m) / n
    beta = (2 * b1 - l1) / np.log(2)
    if beta <= 0:
        return float("nan")
    location = l1 - 0.5772156649015329 * beta
    return float(1.0 - np.exp(-np.exp(-(1.0 - location) / beta)))


def crossing(path):
    with open(path) as f:
        for line in f:
            if line.startswith("crossing "):
                return float(line.split()[1])
    raise RuntimeError(f"{path}: no crossing line")


def main():
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    a.add_argument("--records", type=int, default=20)
    a.add_argument("--seconds", type=float, default=3000.0)
    a.add_argument("--inputs", nargs="+", default=list(bench_plant.INPUTS))
    a.add_argument("--rates", nargs="+", default=["0", "1/h", "4/h"])
    a.add_argument("--draw", type=int, default=7)
    a.add_argument("--residuals", default="per-sensor",
                   help="bgc's --residuals for both the calibration and the records")
    a.add_argument("--counts", type=int, default=0,
                   help="encoders of this many counts per revolution (speed from counts) "
                        "instead of Gaussian noise")
    a.add_argument("--where", action="store_true",
                   help="print where each record came nearest to an alarm")
    args = a.parse_args()
    params = bench_plant.draw(args.draw) if args.draw else dict(bench_plant.MODEL)
    print(f"plant: {' '.join(f'{k}={v:.5g}' for k, v in params.items())}")
    print("input   rate   p per 200 s   predicted   spans   episodes   records with any   samples"
          "   largest |r|/threshold (median, max)   Gumbel P(record crosses) vs stated")
    with tempfile.TemporaryDirectory() as tmp:
        for input in args.inputs:
            clean = bench_plant.simulate(params, input, args.seconds, sigma=0.0)
            calibration = os.path.join(tmp, "calibration.parquet")
            write(calibration, *noisy(clean, 1, int(CALIBRATION_SECONDS * 1000) + 1,
                                      args.counts))
            kept = {}
            for rate in args.rates:
                kept[rate] = os.path.join(tmp, f"{rate.replace('/', '_')}.cal")
                subprocess.run(
                    [args.bgc, "residuals", MODEL, calibration, "--calibrate", calibration,
                     "--false-alarm-rate", rate, "--save-calibration", kept[rate],
                     "-o", os.devnull, "--residuals", args.residuals],
                    check=True, capture_output=True)
            counts = {rate: [0, 0, 0, 0] for rate in args.rates}
            maxima = {rate: [] for rate in args.rates}
            for k in range(args.records):
                record = os.path.join(tmp, "record.parquet")
                write(record, *noisy(clean, 100 + k, len(clean[0]), args.counts))
                for rate in args.rates:
                    out = os.path.join(tmp, "r.csv")
                    subprocess.run(
                        [args.bgc, "residuals", MODEL, record, "--calibration", kept[rate],
                         "--no-size", "-o", out, "--residuals", args.residuals],
                        check=True, capture_output=True)
                    runs, spans, samples = episodes(out)
                    maxima[rate].append(nearest(out))
                    c = counts[rate]
                    c[0] += runs
                    c[1] += spans
                    c[2] += runs > 0
                    c[3] += samples
            for rate in args.rates:
                p = crossing(kept[rate])
                predicted = args.records * args.seconds / CALIBRATION_SECONDS * p
                runs, spans, records, samples = counts[rate]
                near = [m[0] for m in maxima[rate]]
                if args.where:
                    for m in maxima[rate]:
                        print(f"  nearest {m[0]:.3f} by {m[1]} at {m[2]:.3f} s")
                stated = 1.0 - (1.0 - p) ** (args.seconds / CALIBRATION_SECONDS)
                print(f"{input:7} {rate:6} {p:11.3g} {predicted:11.2f} {spans:7} {runs:10} "
                      f"{records:8} of {args.records}   {samples}   "
                      f"{np.median(near):.3f}, {np.max(near):.3f}   "
                      f"{gumbel_crossing(near):.3g} vs {stated:.3g}", flush=True)


if __name__ == "__main__":
    main()
