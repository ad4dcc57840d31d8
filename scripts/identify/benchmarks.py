#!/usr/bin/env python3
"""Identification on plants drawn off their models, simulated by scipy: does `bgc identify`
recover the plant's parameters, do its 95 % intervals hold them, and does any run exit 0 with
a cost above its start or a value that is not a number?

Outside CI (minutes). For each plant and each seed (seeds 1000.. by default, never used in
development), the plant's free parameters are drawn uniformly within ±20 % of the model's
(numpy's default_rng(seed)); scipy's solve_ivp (LSODA, rtol 1e-10, atol 1e-12) integrates it
from rest, its inputs linear between the recorded samples (what a first-order hold gives, and
what bgc's copy of the model assumes); Gaussian noise of the stated level is added to each
sensor. `bgc identify` then fits the model, started from its own values, by each criterion,
and validates the fit on another run of the plant (other input phases, other noise): its
simulation error over the sensor's noise (1 is a model as good as the noise allows).
A parameter counts as recovered within 2 % of the plant's value; an interval holds when the
plant's value lies within the estimate ± its half-width.

Plants (their models in scripts/identify/plants/ and models/):
- level: a tank filled by a pump and drained through an orifice, its level measured, sampled
  every 4 s, 1,024 samples (the single-tank part of the cascaded-tanks benchmark); A fixed
  (one level sensor holds A, kp and c only as ratios).
- duffing: a mass on a hardening spring, its position measured, sampled 9 times per period of
  its linear resonance, 2,000 samples (the Silverbox's physics).
- bench: models/backlash_bench.bg (`bench_plant.py`'s plant), its sine input, 30 s at 1 kHz,
  σ = 1e-4 on both encoders; without the motor current, Re, L, Je, fe, K, Js and fs are
  known only up to one common scaling (structural, printed as such): counted are the
  parameters the ARRs determine (ke, N, j0, gamma).
- three_tank: models/three_tank.bg, three pressures, 1 s steps, 2,000 samples; rho, g and Sn
  fixed (the pipes' coefficients hold Sn only as products).

Usage: benchmarks.py [--bgc target/release/bgc] [--plants bench level duffing three_tank]
                     [--seeds 1000 1001 ...] [--criteria simulation equation]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
from scipy.integrate import solve_ivp

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def multisine(rng, t, frequencies, amplitude):
    phases = rng.uniform(0, 2 * np.pi, len(frequencies))
    return amplitude * sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(frequencies, phases))


def linear(t, samples):
    """The input between samples: linear, as bgc's copy assumes."""
    return lambda s: np.interp(s, t, samples)


def level(rng, p):
    step, rows = 4.0, 1024
    t = np.arange(rows) * step
    u = 5.0 + multisine(rng, t, [1 / 2000, 1 / 900, 1 / 500, 1 / 300, 1 / 150], 0.8)
    uf = linear(t, u)

    def f(s, x):
        h = max(x[0], 0.0)
        return [(p["kp"] * uf(s) - p["c"] * np.sqrt(h)) / p["A"]]

    x = integrate(f, [0.0], t)
    return t, {"u": u}, {"h": x[0]}, {"h": 0.02}


def duffing(rng, p):
    f0 = np.sqrt(1.0 / 1.0e-3) / (2 * np.pi)  # the model's linear resonance
    step, rows = 1 / (9 * f0), 2000
    t = np.arange(rows) * step
    frequencies = np.linspace(0.1, 1.6, 24) * f0
    force = multisine(rng, t, frequencies, 0.0004)
    ff = linear(t, force)

    def f(s, x):
        q, v = x
        return [v, (ff(s) - p["b"] * v - p["k1"] * q - p["k3"] * q ** 3) / p["m"]]

    x = integrate(f, [0.0, 0.0], t)
    return t, {"F": force}, {"x": x[0]}, {"x": 1e-5}


def three_tank(rng, p):
    step, rows = 1.0, 2000
    t = np.arange(rows) * step
    q1 = 5e-5 + multisine(rng, t, [1 / 900, 1 / 400, 1 / 170, 1 / 60], 1.2e-5)
    q2 = 3e-5 + multisine(rng, t, [1 / 700, 1 / 300, 1 / 130, 1 / 50], 1.0e-5)
    f1, f2 = linear(t, q1), linear(t, q2)

    def orifice(az, dp):
        return az * p["Sn"] * np.sign(dp) * np.sqrt(2 * abs(dp) / p["rho"])

    def f(s, x):
        p1, p2, p3 = x
        c = p["A"] / (p["rho"] * p["g"])
        q13 = orifice(p["az1"], p1 - p3)
        q32 = orifice(p["az3"], p3 - p2)
        q20 = orifice(p["az2"], p2)
        return [(f1(s) - q13) / c, (f2(s) + q32 - q20) / c, (q13 - q32) / c]

    x = integrate(f, [0.0, 0.0, 0.0], t)
    return t, {"Q1": q1, "Q2": q2}, {"p1": x[0], "p2": x[1], "p3": x[2]}, \
        {"p1": 5.0, "p2": 5.0, "p3": 5.0}


def bench(rng, p):
    """The reference bench (`bench_plant.py`), its sine input, 30 s at 1 kHz."""
    import bench_plant
    t, u, y1, y2 = bench_plant.simulate(p, input="sine", seconds=30.0, sigma=0.0)
    return t, {"U0": u}, {"y1": y1, "y2": y2}, {"y1": 1e-4, "y2": 1e-4}


def integrate(f, x0, t):
    out = solve_ivp(f, (t[0], t[-1]), x0, method="LSODA", t_eval=t, rtol=1e-10, atol=1e-12,
                    max_step=(t[1] - t[0]))
    if not out.success:
        raise RuntimeError(out.message)
    return out.y


sys.path.insert(0, HERE)

# Each plant: its model, its simulation, the model's values, the parameters held at them (not
# drawn, not fitted), and the parameters the plant's sensors determine (None: all fitted).
PLANTS = {
    "bench": (os.path.join(ROOT, "models", "backlash_bench.bg"), bench,
              {"Re": 0.3, "L": 0.5, "ke": 0.5, "Je": 0.8, "fe": 0.1, "K": 1.0, "N": 5.0,
               "Js": 10.0, "fs": 8.0, "j0": 0.2, "gamma": 2.5}, []),
    "level": (os.path.join(HERE, "plants", "level_tank.bg"), level,
              {"A": 1.0, "kp": 0.05, "c": 0.04}, ["A"]),
    "duffing": (os.path.join(HERE, "plants", "duffing.bg"), duffing,
                {"m": 1.0e-3, "b": 2.0e-3, "k1": 1.0, "k3": 2.0e3}, []),
    "three_tank": (os.path.join(ROOT, "models", "three_tank.bg"), three_tank,
                   {"rho": 1000.0, "g": 9.81, "A": 0.0154, "Sn": 5e-5, "az1": 0.5,
                    "az3": 0.45, "az2": 0.6}, ["rho", "g", "Sn"]),
}

# The bench's parameters its two encoders determine.
DETERMINED = ("ke", "N", "j0", "gamma")

VALIDATION = re.compile(r"# validation on \S+: (\w+)'s simulation error RMS \S+ with the "
                        r"model's values, (\S+) fitted")

LINE = re.compile(r"^(\w+) = (\S+)\s+# (.*)$")


def parse(text):
    found = {}
    for line in text.splitlines():
        m = LINE.match(line)
        if not m:
            continue
        name, value, note = m.groups()
        hw = re.match(r"± (\S+) \(95 %\)", note)
        found[name] = (float(value), float(hw.group(1)) if hw else None, note)
    cost = re.search(r"cost .* (\S+) with the model's values, (\S+) fitted", text)
    return found, (float(cost.group(1)), float(cost.group(2))) if cost else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    ap.add_argument("--plants", nargs="+", default=["level", "duffing", "three_tank"])
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(1000, 1010)))
    ap.add_argument("--criteria", nargs="+", default=["simulation", "equation"])
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for name in a.plants:
            model, simulate, nominal, fixed = PLANTS[name]
            tally = {c: {"within": 0, "held": 0, "count": 0, "bad": 0, "runs": 0}
                     for c in a.criteria}
            for seed in a.seeds:
                rng = np.random.default_rng(seed)
                plant = {k: (v if k in fixed else v * rng.uniform(0.8, 1.2))
                         for k, v in nominal.items()}
                t, inputs, sensors, sigma = simulate(rng, plant)
                path = os.path.join(folder, "%s_%d.csv" % (name, seed))
                columns = {"t": t, **inputs}
                for s, y in sensors.items():
                    columns[s] = y + sigma[s] * rng.standard_normal(len(y))
                np.savetxt(path, np.column_stack(list(columns.values())), delimiter=",",
                           header=",".join(columns), comments="", fmt="%.12g")
                # Another run of the same plant (other input phases, other noise), to
                # validate on: the simulation error the benchmarks publish.
                other = os.path.join(folder, "%s_%d_validation.csv" % (name, seed))
                t2, inputs2, sensors2, _ = simulate(rng, plant)
                columns2 = {"t": t2, **inputs2}
                for s, y in sensors2.items():
                    columns2[s] = y + sigma[s] * rng.standard_normal(len(y))
                np.savetxt(other, np.column_stack(list(columns2.values())), delimiter=",",
                           header=",".join(columns2), comments="", fmt="%.12g")
                for criterion in a.criteria:
                    args = [a.bgc, "identify", model, path, "--criterion", criterion,
                            "--validate", other]
                    if name == "bench":
                        args += ["--window", "51"]
                    for k in fixed:
                        args += ["--fix", k]
                    out = subprocess.run(args, capture_output=True, text=True)
                    row = tally[criterion]
                    row["runs"] += 1
                    if out.returncode != 0:
                        print("  %s seed %d %s: exit %d: %s" % (name, seed, criterion,
                              out.returncode, out.stderr.strip().splitlines()[-1:]))
                        continue
                    found, cost = parse(out.stdout)
                    for sensor, fitted in VALIDATION.findall(out.stdout):
                        row.setdefault("validation", []).append(float(fitted) / sigma[sensor])
                    bad = cost is None or not (cost[1] <= cost[0]) or any(
                        not np.isfinite(v) for v, _, _ in found.values())
                    row["bad"] += bad
                    errors = []
                    for k, truth in plant.items():
                        if k in fixed or k not in found or (
                                name == "bench" and k not in DETERMINED):
                            continue
                        value, hw, note = found[k]
                        error = value / truth - 1
                        row["count"] += 1
                        row["within"] += abs(error) <= 0.02
                        row["held"] += hw is not None and abs(value - truth) <= hw
                        errors.append("%s %+.2f%%%s" % (k, 100 * error,
                                      "" if hw is not None and abs(value - truth) <= hw
                                      else "!"))
                    print("  %s seed %d %-10s %s" % (name, seed, criterion, "  ".join(errors)),
                          flush=True)
            for criterion, row in tally.items():
                n = max(row["count"], 1)
                print("%s, %s error: %d of %d estimates within 2 %% of the plant (%.0f %%), "
                      "%d intervals hold it (%.0f %%); %d of %d runs with a cost above the "
                      "start or a value that is not a number" % (
                          name, criterion, row["within"], row["count"],
                          100 * row["within"] / n, row["held"], 100 * row["held"] / n,
                          row["bad"], row["runs"]), flush=True)
                if row.get("validation"):
                    v = np.array(row["validation"])
                    print("  %s, %s error: simulation error on the validation records, over "
                          "the sensor's noise: median %.3f, largest %.3f" % (
                              name, criterion, np.median(v), v.max()), flush=True)


if __name__ == "__main__":
    sys.exit(main())
