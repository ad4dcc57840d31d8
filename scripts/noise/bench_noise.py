#!/usr/bin/env python3
"""The backlash bench on noisy records: bgc's residuals and faultdiagnosistoolbox's, side by side.

Outside CI: it takes minutes and writes a few hundred megabytes under a temporary folder.
Needs bgc built in release mode (`cargo build --release -p bgc`), numpy, and for the
comparison faultdiagnosistoolbox (`pip install faultdiagnosistoolbox`, which brings sympy);
without it only bgc's residuals are measured.

Per input (an open-loop square 10 ± 5 V of period 10 s, the sine of
`scenarios/bench_dead_zone.scn`, and a closed loop: a PI controller of the load speed, its
voltage recorded as U0) and per fault (`Re` × 1.5, `j0` × 3, both from 51.25 % of the
record):
- scipy (scripts/identify/bench_plant.py, not bgc) simulates the plant with its parameters
  drawn within ±3 % of the model's (`--draw`, 0: the model's own), from rest, and writes the
  faulty record (noise seed 2) and a healthy one (seed 1), 1 kHz, Gaussian noise σ = 1e-4
  rad/s on both encoders;
- bgc: `bgc residuals MODEL RECORD --calibrate HEALTHY` with no other option, and with
  `--realise direct` (the relations as written, derivatives estimated);
- faultdiagnosistoolbox at its best: the model's equations (the plant bgc simulates: the
  link's twist and the dead zone's argument are one integral, both from zero), its MSOs, for
  each one a sequential residual generator in integral causality (`SeqResGen`, its generated
  C in batch mode, built here as a Python extension: needs a C compiler and setuptools),
  given the parameters bgc's calibration fits to the healthy record (`--nominal`: the
  model's), integrated by forward Euler at `--substeps` steps per sample (10; the inputs
  joined by straight lines), so that its thresholds are set by the noise and not by its
  own integration error at the 1-ms step, run on the same records from the plant's
  initial state; each threshold is stated as bgc's is:
  at least the largest |r| on the healthy record times 1.2, and at least the level that
  the healthy record's noise, drawn again (`--draws` draws of fresh noise of the deviation
  read from each encoder's third differences, added and taken away), makes the residual
  cross with probability 1e-3, from their maxima as a Gumbel law (L-moments, location and
  scale one standard error higher) -- the rule of bgc's `--calibrate`;
- for each residual: its RMS before the fault, its fault-to-noise ratio (RMS of its change
  after the fault, from 1 s on, over that RMS: a figure that grows with the record for a
  residual integrated from the start), **the margin at equal time** (the median of
  |r|/threshold from 1 s to 2 s after the fault; for bgc's residuals with a hold, of the
  larger of the onset test's and the hold's, as the alarm is either's) and **the delay** (from the fault to the
  first alarm), the share of samples in alarm from 1 s after the fault, and the alarms
  before it (from a quarter second before it: bgc's centred estimates read up to half their
  window ahead).

Usage: bench_noise.py [--bgc target/release/bgc] [--seconds 1000] [--draws 16] [--draw 7]
                      [--inputs square sine closed] [--no-fdt] [--no-direct]
                      [--substeps 10] [--nominal] [--variant "--estimator modulating" ...]
                      [--partial]
"""

import argparse
import contextlib
import csv
import importlib
import io
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "identify"))
import bench_plant  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")
FAULTS = {"Re": 1.5, "j0": 3.0}
PARAMS = {"Re": 0.3, "L": 0.5, "ke": 0.5, "Je": 0.8, "fe": 0.1, "K": 1.0, "N": 5.0,
          "Js": 10.0, "fs": 8.0, "j0": 0.2, "gamma": 2.5}
MARGIN = 0.2
LOOKAHEAD = 0.25


def simulate(plant, out, seconds, input, seed, fault=()):
    bench_plant.write_csv(out, *bench_plant.simulate(plant, input, seconds, fault, seed=seed))


def read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    k = {name: j for j, name in enumerate(rows[0])}
    data = np.array([[float(r[k[c]]) for c in ("t", "U0", "y1", "y2")] for r in rows[1:]])
    return data


def bgc_residuals(bgc, record, healthy, extra):
    """Each residual's column, alarm and threshold, and its decision's margin: the larger of
    its onset test's |r|/threshold and, where it has one, its hold's."""
    out = subprocess.run([bgc, "residuals", MODEL, record, "--calibrate", healthy] + extra,
                         check=True, capture_output=True, text=True).stdout
    rows = list(csv.reader(out.splitlines()))
    header, body = rows[0], rows[1:]
    at = {name: j for j, name in enumerate(header)}
    names = [h[6:] for h in header if h.startswith("alarm_")]

    def column(name):
        j = at[name]
        return np.array([float(r[j]) if r[j] else np.nan for r in body])

    t = column("t")
    result = []
    for name in names:
        r, level = column(name), column(f"threshold_{name}")
        ratio = np.abs(r) / level
        if f"hold_{name}" in at:
            held = np.abs(column(f"hold_{name}")) / column(f"hold_threshold_{name}")
            ratio = np.fmax(ratio, held)
        result.append((name, t, r, column(f"alarm_{name}") > 0.5, level, ratio))
    return result


def fdt_generators(tmp):
    """faultdiagnosistoolbox's residual generators in integral causality, one per MSO."""
    import faultdiagnosistoolbox as fdt
    import sympy as sym

    names = {"x": ["i", "w1", "w2", "q", "di", "dw1", "dw2", "dq"],
             "f": ["fRe", "fw", "fy1", "fy2"], "z": ["U0", "y1", "y2"],
             "parameters": list(PARAMS)}
    s = {n: sym.Symbol(n) for group in names.values() for n in group}
    K, j0, gamma, q = s["K"], s["j0"], s["gamma"], s["q"]
    wdz = -4 * K * j0 * (1 - sym.exp(-gamma * q)) / (1 + sym.exp(-gamma * q))
    rels = [
        -s["L"] * s["di"] + s["U0"] - s["Re"] * s["i"] - s["ke"] * s["w1"] + s["fRe"],
        -s["Je"] * s["dw1"] + s["ke"] * s["i"] - s["fe"] * s["w1"] - (K * q + wdz) + s["fw"],
        -s["dq"] + s["w1"] - s["N"] * s["w2"],
        -s["Js"] * s["dw2"] + s["N"] * (K * q + wdz) - s["fs"] * s["w2"] + s["fw"],
        fdt.DiffConstraint("di", "i"), fdt.DiffConstraint("dw1", "w1"),
        fdt.DiffConstraint("dw2", "w2"), fdt.DiffConstraint("dq", "q"),
        -s["y1"] + s["w1"] + s["fy1"], -s["y2"] + s["w2"] + s["fy2"],
    ]
    model = fdt.DiagnosisModel(dict(type="Symbolic", rels=rels, **names), name="bench")
    here = os.getcwd()
    os.chdir(tmp)
    sys.path.insert(0, tmp)
    generators = []
    try:
        for k, mso in enumerate(model.MSO()):
            for eq in mso:
                gamma_ = model.Matching([e for e in mso if e != eq])
                if gamma_.matchType == "int":
                    name = f"fdt_mso{k + 1}"
                    # Its generated C, in batch mode (a whole record per call), built as a
                    # Python extension: the Python it also generates takes minutes per
                    # record at ten Euler steps per sample.
                    with contextlib.redirect_stdout(io.StringIO()):
                        model.SeqResGen(gamma_, eq, name, language="C", batch=True)
                    subprocess.run([sys.executable, f"{name}_setup.py", "build_ext", "--inplace"],
                                   check=True, capture_output=True)
                    generators.append((name, getattr(importlib.import_module(name), name)))
                    break
    finally:
        os.chdir(here)
    return generators


def fdt_run(generator, data, params, substeps):
    """The residual at each sample, integrated by forward Euler at `substeps` steps per
    sample (the inputs joined by straight lines between samples)."""
    t, z = data[:, 0], data[:, 1:]
    n = len(t)
    fine = np.arange((n - 1) * substeps + 1) / substeps
    zf = np.column_stack([np.interp(fine, np.arange(n), z[:, c]) for c in range(z.shape[1])])
    state = {"i": 0.0, "q": 0.0, "w1": z[0, 1], "w2": z[0, 2]}
    r = np.asarray(generator(np.ascontiguousarray(zf), state, params, 1e-3 / substeps))
    return r[::substeps]


def partial_run(sensor, data, p):
    """A copy of the part of the model one encoder's reading is compared with, the other
    encoder's measured speed imposed on it (`sensor` 1: the motor's current and speed and
    the twist, driven by U0 and y2; 2: the twist and the load's speed, driven by y1), from
    rest, by the classic Runge-Kutta scheme at the sample step, the signals joined by
    straight lines between samples: the residual `y - ŷ` at each sample. A prototype of a
    realisation bgc does not have yet, measured here beside the two it has."""
    t, u, y1, y2 = (data[:, c].tolist() for c in range(4))
    h = t[1] - t[0]
    K, j0, half_gamma, N = p["K"], p["j0"], 0.5 * p["gamma"], p["N"]

    def torque(z):
        return K * z - 4.0 * K * j0 * math.tanh(half_gamma * z)

    if sensor == 1:
        Re, L, ke, Je, fe = p["Re"], p["L"], p["ke"], p["Je"], p["fe"]

        def f(x, v, w):
            i, w1, z = x
            return ((v - Re * i - ke * w1) / L, (ke * i - fe * w1 - torque(z)) / Je,
                    w1 - N * w)

        drive, measured, out = (u, y2), y1, 1
        x = (0.0, 0.0, 0.0)
    else:
        Js, fs = p["Js"], p["fs"]

        def f(x, v, _):
            z, w2 = x
            return (v - N * w2, (N * torque(z) - fs * w2) / Js)

        drive, measured, out = (y1, y1), y2, 1
        x = (0.0, 0.0)
    a, b = drive
    r = [measured[0] - x[out]]
    for k in range(len(t) - 1):
        a0, a1, b0, b1 = a[k], a[k + 1], b[k], b[k + 1]
        am, bm = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
        k1 = f(x, a0, b0)
        k2 = f(tuple(xi + 0.5 * h * ki for xi, ki in zip(x, k1)), am, bm)
        k3 = f(tuple(xi + 0.5 * h * ki for xi, ki in zip(x, k2)), am, bm)
        k4 = f(tuple(xi + h * ki for xi, ki in zip(x, k3)), a1, b1)
        x = tuple(xi + h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
                  for xi, c1, c2, c3, c4 in zip(x, k1, k2, k3, k4))
        r.append(measured[k + 1] - x[out])
    return np.asarray(r)


def deviation(x):
    """A column's white-noise deviation from its third differences, as bgc reads it."""
    d = np.abs(x[3:] - 3 * x[2:-1] + 3 * x[1:-2] - x[:-3])
    return float(np.median(d) / 0.6745 / np.sqrt(20.0))


def gumbel_level(maxima, p):
    """bgc's Gumbel level (calibrate/replicas.rs): L-moments, each raised a standard error."""
    m = np.sort(np.asarray(maxima))
    n = len(m)
    l1 = m.mean()
    b1 = np.sum(np.arange(n) / (n - 1) * m) / n
    l2 = 2 * b1 - l1
    error = 1 / np.sqrt(n)
    beta = l2 / np.log(2) * (1 + error)
    location = l1 - 0.5772156649015329 * beta + beta * error
    return location - beta * np.log(-np.log1p(-p))


def fdt_level(run, healthy, draws):
    """A faultdiagnosistoolbox residual's threshold by bgc's rule (see the module's text);
    `run` gives its residual on a record."""
    seen = (1 + MARGIN) * np.max(np.abs(run(healthy)))
    rng = np.random.default_rng(0x6263)
    sigma = [deviation(healthy[:, c]) for c in (2, 3)]
    maxima = []
    for _ in range(draws):
        noise = np.zeros_like(healthy)
        for c, s in zip((2, 3), sigma):
            noise[:, c] = s * rng.standard_normal(len(healthy))
        up = run(healthy + noise)
        down = run(healthy - noise)
        maxima.append(np.max(np.abs(0.5 * (up - down))))
    return max(seen, gumbel_level(maxima, 1e-3))


def fitted(bgc, healthy, tmp):
    """The parameters bgc's calibration fits to the healthy record (its kept calibration's
    `param` lines), for the other tool at its best."""
    kept = os.path.join(tmp, "fitted.cal")
    subprocess.run([bgc, "residuals", MODEL, healthy, "--calibrate", healthy, "--no-size",
                    "--save-calibration", kept, "-o", os.devnull], check=True,
                   capture_output=True)
    values = dict(PARAMS)
    with open(kept) as f:
        for line in f:
            words = line.split()
            if len(words) == 3 and words[0] == "param" and words[1] in values:
                values[words[1]] = float(words[2])
    return values


def report(label, t, r, alarm, at, level, ratio=None):
    # bgc's centred estimates at t read samples up to half a window later (at most 0.25 s):
    # alarms count as before the fault from that far before it.
    after, early = t > at + 1.0, t < at - LOOKAHEAD
    # Noise from before what any estimate of a faulty sample reads.
    rms = float(np.sqrt(np.mean(r[early] ** 2)))
    change = r[after] - np.mean(r[early])
    snr = float(np.sqrt(np.mean(change ** 2)) / rms) if rms > 0 else float("inf")
    window = (t >= at + 1.0) & (t <= at + 2.0)
    # The decision's margin: where a residual has a hold, the larger of its two tests'.
    ratio = np.abs(r) / level if ratio is None else ratio
    margin = float(np.nanmedian(ratio[window]))
    seen = np.nonzero(alarm & (t >= at - LOOKAHEAD))[0]
    delay = f"{t[seen[0]] - at:+.3f} s" if seen.size else "none"
    print(f"| {label} | {rms:.3g} | {snr:.3g} | {margin:.3g} | {delay} | "
          f"{100 * np.mean(alarm[after]):.1f} % | {int(np.sum(alarm[early]))} |")
    sys.stdout.flush()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    p.add_argument("--seconds", type=float, default=1000.0)
    p.add_argument("--draws", type=int, default=16)
    p.add_argument("--draw", type=int, default=7)
    p.add_argument("--inputs", nargs="+", default=list(bench_plant.INPUTS))
    p.add_argument("--no-fdt", action="store_true")
    p.add_argument("--no-direct", action="store_true",
                   help="leave out bgc with the relations as written")
    p.add_argument("--substeps", type=int, default=10,
                   help="faultdiagnosistoolbox's Euler steps per sample")
    p.add_argument("--variant", action="append", default=[], metavar="ARGS",
                   help="bgc again with these options added (one string), beside its defaults")
    p.add_argument("--partial", action="store_true",
                   help="also each encoder against a copy of the part of the model the other "
                        "encoder drives (a prototype), thresholds by the same rule")
    p.add_argument("--nominal", dest="fitted", action="store_false",
                   help="give faultdiagnosistoolbox the model's values, not bgc's fitted ones")
    a = p.parse_args()
    at = a.seconds * 0.5125
    plant = bench_plant.draw(a.draw) if a.draw else dict(bench_plant.MODEL)
    print(f"plant: {' '.join(f'{k}={v:.5g}' for k, v in plant.items())}\n")
    with tempfile.TemporaryDirectory() as tmp:
        generators = [] if a.no_fdt else fdt_generators(tmp)
        print("| input | fault | tool | residual | healthy RMS | fault/noise | "
              "margin 1-2 s after | delay | in alarm from 1 s after | alarms before |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for input_name in a.inputs:
            healthy = os.path.join(tmp, f"{input_name}_healthy.csv")
            simulate(plant, healthy, a.seconds, input_name, 1)
            healthy_data = read(healthy)
            params = fitted(a.bgc, healthy, tmp) if a.fitted and generators else PARAMS
            runs = {name: (lambda data, g=g: fdt_run(g, data, params, a.substeps))
                    for name, g in generators}
            if a.partial:
                if not generators:
                    params = fitted(a.bgc, healthy, tmp) if a.fitted else PARAMS
                runs.update({f"partial y{k}": (lambda data, k=k: partial_run(k, data, params))
                             for k in (1, 2)})
            levels = {name: fdt_level(run, healthy_data, a.draws) for name, run in runs.items()}
            for fault_name, factor in FAULTS.items():
                record = os.path.join(tmp, f"{input_name}_{fault_name}.csv")
                simulate(plant, record, a.seconds, input_name, 2, [(fault_name, factor, at)])
                hows = [("bgc", [])] + ([] if a.no_direct else
                                        [("bgc --realise direct", ["--realise", "direct"])])
                hows += [(f"bgc {v}", v.split()) for v in a.variant]
                for how, extra in hows:
                    for name, t, r, alarm, level, ratio in bgc_residuals(a.bgc, record, healthy,
                                                                         extra):
                        report(f"{input_name} | {fault_name} | {how} | {name}", t, r, alarm, at,
                               level, ratio)
                data = read(record)
                for name, run in runs.items():
                    r = run(data)
                    tool = "prototype" if name.startswith("partial") else "faultdiagnosistoolbox"
                    report(f"{input_name} | {fault_name} | {tool} | {name}",
                           data[:, 0], r, np.abs(r) > levels[name], at,
                           np.full(len(r), levels[name]))


if __name__ == "__main__":
    main()
