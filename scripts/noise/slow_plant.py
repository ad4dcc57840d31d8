#!/usr/bin/env python3
"""Sizes on a slow plant sampled every 0.5 s: do their intervals hold the truth?

Outside CI: about a second per record. Needs bgc built in release mode (`cargo build
--release -p bgc`), numpy and scipy.

The plant is `models/thermal_two_zone.bg` (an oven and its casing: time constants of about
3 and 30 minutes), simulated by scipy (LSODA, not bgc) with its four parameters drawn
within +-3 % of the model's (one draw per seed), driven by a heater switched to a random
level every 10 to 30 minutes, sampled every 0.5 s for four hours, Gaussian noise on every
sensor (0.01 K on both temperatures, 0.5 W on the heat-flux meter). Per seed:
- a healthy record (heater and noise seed 3 k) calibrated on with defaults (`--calibrate`,
  which fits the model to it first), the calibration kept (`--save-calibration`: it decides
  as the fresh one does);
- another healthy record (seed 3 k + 1) monitored with it: its alarms are false ones;
- a faulty record per fault (seed 3 k + 2), the fault from two hours on, monitored with it;
- the first-ranked size: is it the faulty parameter, and does its 95 % interval hold the
  plant's true value after the fault?

Usage: slow_plant.py [--bgc target/release/bgc] [--seeds 20] [--faults R2=0.5 R12=2 C2=0.5]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
from scipy.integrate import solve_ivp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "thermal_two_zone.bg")
NOMINAL = {"C1": 4000.0, "C2": 9000.0, "R12": 0.05, "R2": 0.2}
STEP = 0.5
SECONDS = 4 * 3600.0
NOISE = {"T1": 0.01, "T2": 0.01, "q12": 0.5}
SIZE = re.compile(r"^\s+1\s+(\S+): (\w+) = (\S+) \S+ ± ([^\s,]+)", re.M)


def draw(seed):
    rng = np.random.default_rng(1000 + seed)
    return {k: v * rng.uniform(0.97, 1.03) for k, v in NOMINAL.items()}


def simulate(plant, path, seed, fault=None):
    """One record: `fault` is (parameter, factor), from half the record on."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, SECONDS + STEP / 2, STEP)
    edges = np.cumsum(rng.uniform(600.0, 1800.0, 64))
    levels = rng.uniform(0.0, 400.0, 65)

    def power(s):
        return levels[np.searchsorted(edges, s, side="right")]

    def value(name, s):
        changed = fault is not None and fault[0] == name and s >= SECONDS / 2
        return plant[name] * (fault[1] if changed else 1.0)

    def rates(s, x):
        t1, t2 = x
        q12 = (t1 - t2) / value("R12", s)
        return [(power(s) - q12) / value("C1", s), (q12 - t2 / value("R2", s)) / value("C2", s)]

    # Each piece between the heater's switches (and the fault) is integrated alone, so
    # that no step is taken across a jump.
    cuts = sorted({0.0, SECONDS, SECONDS / 2, *[e for e in edges if e < SECONDS]})
    x = [0.0, 0.0]
    states = []
    for a, b in zip(cuts, cuts[1:]):
        inside = t[(t >= a) & ((t < b) | (b == SECONDS))]
        sol = solve_ivp(rates, (a, b), x, method="LSODA", rtol=1e-10, atol=1e-10,
                        dense_output=True)
        states.append(sol.sol(inside))
        x = list(sol.y[:, -1])
    t1, t2 = np.concatenate(states, axis=1)
    r12 = np.array([value("R12", s) for s in t])
    q12 = (t1 - t2) / r12
    noisy = {"T1": t1, "T2": t2, "q12": q12}
    columns = [t, power(t)] + [noisy[k] + NOISE[k] * rng.standard_normal(t.size) for k in noisy]
    np.savetxt(path, np.column_stack(columns), delimiter=",", header="t,P,T1,T2,q12",
               comments="", fmt="%.10g")


def calibrate(bgc, healthy, kept):
    run = subprocess.run([bgc, "residuals", MODEL, healthy, "--calibrate", healthy, "--no-size",
                          "--save-calibration", kept, "-o", os.devnull],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(run.stderr)


def monitor(bgc, record, kept):
    """The first-ranked size (component, parameter, value, half-width) or None, and the
    samples in alarm."""
    out = os.path.join(os.path.dirname(kept), "residuals.csv")
    run = subprocess.run([bgc, "residuals", MODEL, record, "--calibration", kept, "-o", out],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(run.stderr)
    with open(out) as f:
        header = f.readline().strip().split(",")
        alarms = [k for k, h in enumerate(header) if h.startswith("alarm_")]
        on = sum(any(row.split(",")[k] == "1" for k in alarms) for row in f)
    found = SIZE.search(run.stderr)
    return found and (found[1], found[2], float(found[3]), float(found[4])), on


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--faults", nargs="+", default=["R2=0.5", "R12=2", "C2=0.5"])
    p.add_argument("--verbose", action="store_true")
    a = p.parse_args()
    print("| fault | seeds | right parameter first | interval holds the truth | "
          "median |error| / half-width | median half-width / value |")
    print("|---|---|---|---|---|---|")
    false = []
    rows = {f: [] for f in a.faults}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(a.seeds):
            plant = draw(seed)
            healthy = os.path.join(tmp, "healthy.csv")
            kept = os.path.join(tmp, "kept.cal")
            simulate(plant, healthy, 3 * seed)
            calibrate(a.bgc, healthy, kept)
            # Another healthy record, with another heater sequence and noise: its alarms
            # are false ones.
            simulate(plant, healthy, 3 * seed + 1)
            false.append(monitor(a.bgc, healthy, kept)[1])
            for fault in a.faults:
                name, factor = fault.split("=")
                record = os.path.join(tmp, "fault.csv")
                simulate(plant, record, 3 * seed + 2, (name, float(factor)))
                found = monitor(a.bgc, record, kept)[0]
                truth = plant[name] * float(factor)
                if a.verbose:
                    print(seed, fault, found, truth, "false alarm samples", false[-1],
                          file=sys.stderr)
                rows[fault].append(found and (found[1] == name, found[2], found[3], truth))
    for fault, found in rows.items():
        right = [f for f in found if f and f[0]]
        errors = [abs(v - truth) / w for _, v, w, truth in right]
        widths = [w / abs(v) for _, v, w, _ in right]
        print(f"| {fault.replace('=', ' × ')} | {len(found)} | {len(right)} | "
              f"{sum(e <= 1.0 for e in errors)} | "
              f"{np.median(errors) if errors else float('nan'):.2f} | "
              f"{np.median(widths) if widths else float('nan'):.2e} |")
    print(f"\nhealthy records with an alarm: {sum(n > 0 for n in false)} of {len(false)} "
          f"({sum(false)} samples)")


if __name__ == "__main__":
    main()
