#!/usr/bin/env python3
"""How often `bgc identify`'s 95 % intervals hold the plant's true parameters, over seeds.

Outside CI (minutes). For each seed k: the bench's 11 parameters drawn within ±3 % of the
model's (`bench_plant.draw(k)`), a healthy record of SECONDS s simulated by scipy
(`bench_plant.simulate`, noise σ on both encoders, seed 1000 + k), `bgc identify` on it;
for each parameter bgc reports as determined, whether its interval holds the true value.
The parameters bgc reports as not determined are listed with its reason.

Usage: coverage.py [--bgc target/release/bgc] [--seeds 20] [--seconds 200]
                   [--input square] [--sigma 1e-4] [-- extra bgc identify options]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import bench_plant

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")
LINE = re.compile(r"^(\w+) = (\S+)\s+# ± (\S+) \(95 %\)")


def one(seed, a, folder, extra):
    truth = bench_plant.draw(seed)
    path = os.path.join(folder, "h%d.csv" % seed)
    bench_plant.write_csv(path, *bench_plant.simulate(truth, a.input, a.seconds,
                                                      seed=1000 + seed, sigma=a.sigma))
    out = subprocess.run([a.bgc, "identify", MODEL, path] + extra, capture_output=True,
                         text=True, check=True).stdout
    os.remove(path)
    found = {}
    for line in out.splitlines():
        m = LINE.match(line)
        if m:
            found[m.group(1)] = (float(m.group(2)), float(m.group(3)))
    notes = [line for line in out.splitlines() if line.startswith("# not determined")]
    return seed, truth, found, notes


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=200.0)
    ap.add_argument("--input", default="square")
    ap.add_argument("--sigma", type=float, default=1e-4)
    a, extra = ap.parse_known_args()
    extra = [x for x in extra if x != "--"]
    held = {}
    with tempfile.TemporaryDirectory() as folder, ThreadPoolExecutor(2) as pool:
        runs = list(pool.map(lambda k: one(k, a, folder, extra), range(1, a.seeds + 1)))
    for seed, truth, found, notes in runs:
        misses = []
        for name, (value, half) in found.items():
            inside = abs(value - truth[name]) <= half
            held.setdefault(name, []).append(inside)
            if not inside:
                misses.append("%s %.6g ± %.2g, true %.6g (%.1f half-widths off)" % (
                    name, value, half, truth[name], abs(value - truth[name]) / half))
        print("seed %d: %d determined, %s" % (
            seed, len(found), "; ".join(misses) if misses else "every interval holds"))
    print("\nparameter  held / seeds")
    for name, flags in held.items():
        print("%-9s  %d / %d" % (name, sum(flags), len(flags)))
    print("\nnot determined (seed 1):")
    for line in runs[0][3]:
        print("  " + line)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    main()
