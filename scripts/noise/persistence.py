#!/usr/bin/env python3
"""Decisions that follow the fault: the share of samples in alarm from 1 s after a persistent
fault to the record's end, and the false alarms before it, with defaults (`--calibrate` on
one healthy record, no other option).

Outside CI (minutes per case). Records simulated by scipy (scripts/identify/bench_plant.py,
not bgc), from rest, σ = 1e-4 rad/s on both encoders (or `--counts N`: encoders of N counts
per revolution, speed from differences of counts, no other noise), 1 kHz. For each input and
each plant (the model's own, then `--draws` plants drawn ±3 % off with seeds 500, 501, ...):
a healthy record of `--calibration` s (noise seed 11, or `--seeds`' first) to calibrate on,
and a record of `--seconds` s (noise seed 12, or `--seeds`' second) with the fault from
half-way. Plants are drawn from seed `--first-draw` (500) on. The faults: the dead zone tripled
(`j0=3*j0`) and the armature resistance × 1.5 (`Re=1.5*Re`).

Printed, per case: the share in alarm (any residual) from 1 s after the fault to the end,
each residual's, the samples in alarm before the fault (false alarms, up to half a second
before it: the estimators read half a window ahead) and what the calibration chose.

Usage: persistence.py [--bgc target/release/bgc] [--inputs square sine closed]
                      [--draws 5] [--seconds 200] [--calibration 200] [--counts 0]
                      [--faults j0=3*j0 Re=1.5*Re] [--seeds 11 12] [--first-draw 500]
"""

import argparse
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(HERE, "..", "identify"))
import bench_plant  # noqa: E402

MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")


def record(path, params, input, seconds, seed, faults, counts):
    t, u, y1, y2 = bench_plant.simulate(params, input, seconds, faults=faults, seed=seed,
                                        counts=counts)
    bench_plant.write_csv(path, t, u, y1, y2)


def shares(csv, at):
    with open(csv) as f:
        names = f.readline().strip().split(",")
    cols = [k for k, n in enumerate(names) if n == "t" or n.startswith("alarm_")]
    d = np.loadtxt(csv, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
    t, alarms = d[:, 0], d[:, 1:] > 0
    anyone = alarms.any(axis=1)
    after = t >= at + 1.0
    before = t < at - 0.5
    per = {names[c][6:]: float(alarms[after, j].mean()) for j, c in enumerate(cols[1:])}
    return float(anyone[after].mean()), int(anyone[before].sum()), per


def case(args, tmp, input, draw, fault):
    params = bench_plant.MODEL if draw is None else bench_plant.draw(draw)
    tag = f"{input}-{draw}-{fault.replace('*', 'x').replace('=', '_')}"
    healthy = os.path.join(tmp, f"h-{input}-{draw}.csv")
    if not os.path.exists(healthy):
        record(healthy, params, input, args.calibration, args.seeds[0], (), args.counts)
    name, rest = fault.split("=")
    factor = float(rest.split("*")[0])
    at = args.seconds / 2
    faulty = os.path.join(tmp, f"f-{tag}.csv")
    record(faulty, params, input, args.seconds, args.seeds[1], [(name, factor, at)],
           args.counts)
    out = os.path.join(tmp, f"r-{tag}.csv")
    run = subprocess.run([args.bgc, "residuals", MODEL, faulty, "--calibrate", healthy,
                          "--no-size", "-o", out] + args.bgc_args, capture_output=True,
                         text=True)
    if run.returncode != 0:
        return f"{tag}: bgc failed: {run.stderr.strip()[-300:]}"
    share, false, per = shares(out, at)
    held = [line for line in run.stderr.splitlines() if "tested twice" in line]
    os.remove(faulty)
    os.remove(out)
    per = " ".join(f"{k} {v * 100:.1f}%" for k, v in per.items())
    return (f"{input:7s} plant {str(draw):5s} {fault:10s} in alarm {share * 100:5.1f} % "
            f"({per}), false {false}" + ("" if held else " (no hold)"))


def main():
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    a.add_argument("--inputs", nargs="+", default=list(bench_plant.INPUTS))
    a.add_argument("--draws", type=int, default=5)
    a.add_argument("--seconds", type=float, default=200.0)
    a.add_argument("--calibration", type=float, default=200.0)
    a.add_argument("--counts", type=int, default=0)
    a.add_argument("--faults", nargs="+", default=["j0=3*j0", "Re=1.5*Re"])
    a.add_argument("--jobs", type=int, default=2)
    a.add_argument("--seeds", type=int, nargs=2, default=[11, 12],
                   help="noise seeds of the healthy and the faulty records")
    a.add_argument("--first-draw", type=int, default=500,
                   help="the first plant draw's seed (the others follow it)")
    a.add_argument("--bgc-args", nargs="*", default=[],
                   help="more options for `bgc residuals` (after --), e.g. --within 20")
    args = a.parse_args()
    plants = [None] + [args.first_draw + k for k in range(args.draws)]
    with tempfile.TemporaryDirectory() as tmp:
        # Each input's and plant's healthy record first, once.
        with ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(lambda ip: record(os.path.join(tmp, f"h-{ip[0]}-{ip[1]}.csv"),
                                            bench_plant.MODEL if ip[1] is None
                                            else bench_plant.draw(ip[1]),
                                            ip[0], args.calibration, args.seeds[0], (),
                                            args.counts),
                          [(i, p) for i in args.inputs for p in plants]))
        cases = [(i, p, f) for i in args.inputs for p in plants for f in args.faults]
        with ThreadPoolExecutor(args.jobs) as pool:
            for line in pool.map(lambda c: case(args, tmp, *c), cases):
                print(line, flush=True)


if __name__ == "__main__":
    main()
