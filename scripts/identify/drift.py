#!/usr/bin/env python3
"""A dead zone that widens: `j0` drifting linearly from the plant's value to three times it
over 500 s, followed by `bgc residuals --calibrate HEALTHY --sizes FILE`.

Outside CI (minutes). The bench drawn within ±3 % of its model (`--draw`), square input,
σ = 1e-4 rad/s, records simulated by scipy (`bench_plant.py`): a 200-s healthy record
(noise seed 1) and a 600-s one whose `j0` drifts from 50 s to 550 s (noise seed 2). Prints,
for each span `--sizes` fitted after the first alarm, the estimate of `j0` against the
plant's value at the span's middle, and the largest relative error.

Usage: drift.py [--bgc target/release/bgc] [--draw 7] [--span 25]
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_plant  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    ap.add_argument("--draw", type=int, default=7)
    ap.add_argument("--span", type=float, default=25.0)
    a = ap.parse_args()
    plant = bench_plant.draw(a.draw)
    j0 = plant["j0"]
    start, end = 50.0, 550.0
    truth = lambda t: j0 + (2.0 * j0) * min(max((t - start) / (end - start), 0.0), 1.0)
    with tempfile.TemporaryDirectory() as folder:
        healthy = os.path.join(folder, "healthy.csv")
        drifting = os.path.join(folder, "drift.csv")
        sizes = os.path.join(folder, "sizes.csv")
        bench_plant.write_csv(healthy, *bench_plant.simulate(plant, "square", 200.0, seed=1))
        bench_plant.write_csv(drifting, *bench_plant.simulate(
            plant, "square", 600.0, ramps=[("j0", j0, 3.0 * j0, start, end)], seed=2))
        done = subprocess.run([a.bgc, "residuals", MODEL, drifting, "--calibrate", healthy,
                               "--size-span", str(a.span), "--sizes", sizes, "-o", os.devnull],
                              capture_output=True, text=True, check=True)
        keep = False
        for line in done.stderr.splitlines():
            if line.startswith("note: alarms from") or line.startswith("note: the fault's size"):
                keep = True
            elif line.startswith("note:") or not line.startswith(" "):
                keep = False
            if keep:
                print(line[:200])
        worst = 0.0
        with open(sizes) as f:
            for row in csv.DictReader(f):
                if row["parameter"] != "j0":
                    print("%s-%s s  %s %s = %s" % (row["from"], row["to"], row["component"],
                                                 row["parameter"], row["value"]))
                    continue
                a0, a1 = float(row["from"]), float(row["to"])
                t = 0.5 * (a0 + a1)
                value = float(row["value"])
                error = value / truth(t) - 1.0
                worst = max(worst, abs(error))
                print("%7.1f-%7.1f s  j0 %.4f (true at the middle %.4f, %+.1f %%)  component %s" % (
                    a0, a1, value, truth(t), 100.0 * error, row["component"]))
        print("largest error: %.1f %%" % (100.0 * worst))


if __name__ == "__main__":
    main()
