#!/usr/bin/env python3
"""The bench whose plant is not its model: `bgc residuals --calibrate HEALTHY` on faulty and
healthy records of a plant whose 11 parameters are drawn within ±3 % of the model's.

Outside CI (minutes). Records simulated by scipy (`bench_plant.py`), σ = 1e-4 rad/s on both
encoders, 1 kHz. For each input (square 10 ± 5 V of period 10 s, sine 6 + 12 sin 0.5t):
- a healthy calibration record (noise seed 1) and, per fault (`j0` × 3, `Re` × 1.5 at the
  record's middle), a faulty record (noise seed 2); `bgc residuals MODEL FAULTY --calibrate
  HEALTHY` with no other option (and with `--keep-model`, the model's values): the share of
  samples with some alarm from 1 s after the fault, and the false-alarm samples before it
  (from a quarter second before it on: the centred estimates read ahead);
- `--healthy N` other healthy records (noise seeds 100..): the records with any alarm and
  their alarm samples, under the same calibration.

Usage: mismatch.py [--bgc target/release/bgc] [--draw 7] [--seconds 200] [--healthy 20]
                   [--inputs square sine] [--keep-model]
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_plant  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")
FAULTS = {"j0 x 3": ("j0", 3.0), "Re x 1.5": ("Re", 1.5)}
LOOKAHEAD = 0.25


def residuals(a, record, healthy, extra):
    out = subprocess.run([a.bgc, "residuals", MODEL, record, "--calibrate", healthy] + extra,
                         capture_output=True, text=True, check=True)
    rows = list(csv.DictReader(out.stdout.splitlines()))
    alarms = [k for k in rows[0] if k.startswith("alarm_")]
    return [(float(r["t"]), any(r[k] == "1" for k in alarms)) for r in rows], out.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    ap.add_argument("--draw", type=int, default=7)
    ap.add_argument("--seconds", type=float, default=200.0)
    ap.add_argument("--healthy", type=int, default=20)
    ap.add_argument("--inputs", nargs="+", default=["square", "sine"])
    ap.add_argument("--keep-model", action="store_true")
    a = ap.parse_args()
    extra = ["--keep-model"] if a.keep_model else []
    plant = bench_plant.draw(a.draw)
    print("plant (draw %d): %s" % (a.draw, " ".join("%s=%.5g" % kv for kv in plant.items())))
    at = a.seconds / 2
    with tempfile.TemporaryDirectory() as folder:
        for input in a.inputs:
            def record(name, seed, faults=()):
                path = os.path.join(folder, "%s_%s.csv" % (input, name))
                bench_plant.write_csv(path, *bench_plant.simulate(
                    plant, input, a.seconds, faults, seed=seed))
                return path
            healthy = record("healthy", 1)
            for label, (name, factor) in FAULTS.items():
                faulty = record(label.replace(" ", ""), 2, [(name, factor, at)])
                rows, said = residuals(a, faulty, healthy, extra)
                after = [x for t, x in rows if t >= at + 1.0]
                before = [x for t, x in rows if t < at - LOOKAHEAD]
                print("%-6s %-8s in alarm from 1 s after the fault: %5.1f %% of %d samples; "
                      "false-alarm samples before it: %d" % (
                          input, label, 100.0 * sum(after) / len(after), len(after),
                          sum(before)))
            with ThreadPoolExecutor(2) as pool:
                others = list(pool.map(
                    lambda k: residuals(a, record("h%d" % k, 100 + k), healthy, extra)[0],
                    range(a.healthy)))
            flagged = [sum(x for _, x in rows) for rows in others]
            print("%-6s healthy records of other seeds: %d of %d with an alarm (%s samples)" % (
                input, sum(1 for f in flagged if f), len(flagged),
                ", ".join(str(f) for f in flagged if f) or "no"))


if __name__ == "__main__":
    main()
