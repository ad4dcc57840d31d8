#!/usr/bin/env python3
"""The backlash bench on noisy records: bgc's residuals and faultdiagnosistoolbox's, side by side.

Outside CI: it takes minutes and writes a few hundred megabytes under a temporary folder.
Needs bgc built in release mode (`cargo build --release -p bgc`), numpy, and for the
comparison faultdiagnosistoolbox (`pip install faultdiagnosistoolbox`, which brings sympy);
without it only bgc's residuals are measured.

Per input (an open-loop square 10 ± 5 V of period 10 s, and the sine of
`scenarios/bench_dead_zone.scn`) and per fault (`Re` × 1.5, `j0` × 3, both from 51.25 % of
the record):
- `bgc simulate` writes the faulty record (seed 2) and a healthy one (seed 1), 1 kHz,
  Gaussian noise σ = 1e-4 rad/s on both encoders;
- bgc: `bgc residuals MODEL RECORD --calibrate HEALTHY` with no other option, and with
  `--realise direct` (the relations as written, derivatives estimated);
- faultdiagnosistoolbox: the model's equations (the plant bgc simulates: the link's twist and
  the dead zone's argument are one integral, both from zero), its MSOs, for each one a
  sequential residual generator in integral causality (`SeqResGen`, forward Euler), run on
  the same records from the plant's initial state; each threshold is calibrated as bgc's
  is: the largest |r| on the healthy record, times 1.2;
- for each residual: its RMS before the fault, its fault-to-noise ratio (RMS of its change
  after the fault, from 1 s on, over that RMS), the share of samples in alarm from 1 s after
  the fault, and the alarms before it (from a quarter second before it: bgc's centred
  estimates read up to half their window ahead).

Usage: bench_noise.py [--bgc target/release/bgc] [--seconds 1000] [--no-fdt]
"""

import argparse
import csv
import importlib
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODEL = os.path.join(ROOT, "models", "backlash_bench.bg")
INPUTS = {
    "square": "10 + 5*sign(sin(0.6283185307179586*t))",
    "sine": "6 + 12*sin(0.5*t)",
}
FAULTS = {"Re": "fault Re = 1.5*Re at {at}", "j0": "fault j0 = 3*j0 at {at}"}
PARAMS = {"Re": 0.3, "L": 0.5, "ke": 0.5, "Je": 0.8, "fe": 0.1, "K": 1.0, "N": 5.0,
          "Js": 10.0, "fs": 8.0, "j0": 0.2, "gamma": 2.5}
MARGIN = 0.2
LOOKAHEAD = 0.25


def simulate(bgc, out, seconds, u, seed, fault=None):
    args = [bgc, "simulate", MODEL, "-e", f"duration {seconds}", "-e", "step 0.001",
            "-e", f"input U0 = {u}", "-e", "noise y1 1e-4", "-e", "noise y2 1e-4",
            "-e", f"seed {seed}", "-o", out]
    if fault:
        args += ["-e", fault]
    subprocess.run(args, check=True)


def read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    k = {name: j for j, name in enumerate(rows[0])}
    data = np.array([[float(r[k[c]]) for c in ("t", "U0", "y1", "y2")] for r in rows[1:]])
    return data


def bgc_residuals(bgc, record, healthy, extra):
    out = subprocess.run([bgc, "residuals", MODEL, record, "--calibrate", healthy] + extra,
                         check=True, capture_output=True, text=True).stdout
    rows = list(csv.reader(out.splitlines()))
    header, body = rows[0], rows[1:]
    n = (len(header) - 3) // 3
    data = np.array([[float(c) if c else np.nan for c in r[: 1 + 3 * n]] for r in body])
    return [(header[1 + k], data[:, 0], data[:, 1 + k], data[:, 1 + 2 * n + k] > 0.5)
            for k in range(n)]


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
                    model.SeqResGen(gamma_, eq, name, language="Python")
                    generators.append((name, getattr(importlib.import_module(name), name)))
                    break
    finally:
        os.chdir(here)
    return generators


def fdt_run(generator, data):
    t, z = data[:, 0], data[:, 1:]
    state = {"i": 0.0, "q": 0.0, "w1": z[0, 1], "w2": z[0, 2]}
    r = np.empty(len(t))
    for k in range(len(t)):
        r[k], state = generator(z[k], state, PARAMS, 1e-3)
    return r


def report(label, t, r, alarm, at):
    # bgc's centred estimates at t read samples up to half a window later (at most 0.25 s):
    # alarms count as before the fault from that far before it.
    after, early = t > at + 1.0, t < at - LOOKAHEAD
    # Noise from before what any estimate of a faulty sample reads.
    rms = float(np.sqrt(np.mean(r[early] ** 2)))
    change = r[after] - np.mean(r[early])
    snr = float(np.sqrt(np.mean(change ** 2)) / rms) if rms > 0 else float("inf")
    print(f"| {label} | {rms:.3g} | {snr:.3g} | {100 * np.mean(alarm[after]):.1f} % | "
          f"{int(np.sum(alarm[early]))} |")
    sys.stdout.flush()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    p.add_argument("--seconds", type=float, default=1000.0)
    p.add_argument("--no-fdt", action="store_true")
    a = p.parse_args()
    at = a.seconds * 0.5125
    with tempfile.TemporaryDirectory() as tmp:
        generators = [] if a.no_fdt else fdt_generators(tmp)
        print("| input | fault | tool | residual | healthy RMS | fault/noise | "
              "in alarm from 1 s after | alarms before |")
        print("|---|---|---|---|---|---|---|---|")
        for input_name, u in INPUTS.items():
            healthy = os.path.join(tmp, f"{input_name}_healthy.csv")
            simulate(a.bgc, healthy, a.seconds, u, 1)
            healthy_data = read(healthy)
            levels = {name: (1 + MARGIN) * np.max(np.abs(fdt_run(g, healthy_data)))
                      for name, g in generators}
            for fault_name, fault in FAULTS.items():
                record = os.path.join(tmp, f"{input_name}_{fault_name}.csv")
                simulate(a.bgc, record, a.seconds, u, 2, fault.format(at=at))
                for how, extra in [("bgc", []), ("bgc --realise direct", ["--realise", "direct"])]:
                    for name, t, r, alarm in bgc_residuals(a.bgc, record, healthy, extra):
                        report(f"{input_name} | {fault_name} | {how} | {name}", t, r, alarm, at)
                data = read(record)
                for name, g in generators:
                    r = fdt_run(g, data)
                    report(f"{input_name} | {fault_name} | faultdiagnosistoolbox | {name}",
                           data[:, 0], r, np.abs(r) > levels[name], at)


if __name__ == "__main__":
    main()
