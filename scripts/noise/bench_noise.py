#!/usr/bin/env python3
"""The backlash bench on noisy records: bgc's residuals, direct and integrated, side by side.

Outside CI (it takes minutes and writes a few hundred megabytes under a temporary folder).
Needs bgc built in release mode (`cargo build --release -p bgc`) and numpy.

What it does, per input (an open-loop square 10 ± 5 V of period 10 s, and the sine of
`scenarios/bench_dead_zone.scn`) and per fault (`Re` × 1.5, `j0` × 3, both from 512.5 s):
- simulates 1,000 s at 1 kHz with Gaussian noise σ = 1e-4 rad/s on both encoders
  (`bgc simulate`), the faulty record with seed 2 and a healthy one with seed 1;
- runs `bgc residuals MODEL RECORD --calibrate HEALTHY` with no other option (and, for
  comparison, with `--realise direct`, the relations as written);
- reports, for each residual: its healthy RMS before the fault, its fault-to-noise ratio
  (RMS of its change after the fault, from 1 s on, over its healthy RMS), the share of
  samples in alarm from 1 s after the fault, and the false alarms before it.

Usage: scripts/noise/bench_noise.py [--bgc target/release/bgc] [--seconds 1000]
"""

import argparse
import csv
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


def simulate(bgc, out, seconds, u, seed, fault=None):
    args = [bgc, "simulate", MODEL, "-e", f"duration {seconds}", "-e", "step 0.001",
            "-e", f"input U0 = {u}", "-e", "noise y1 1e-4", "-e", "noise y2 1e-4",
            "-e", f"seed {seed}", "-o", out]
    if fault:
        args += ["-e", fault]
    subprocess.run(args, check=True)


def residuals(bgc, record, healthy, extra):
    out = subprocess.run([bgc, "residuals", MODEL, record, "--calibrate", healthy] + extra,
                         check=True, capture_output=True, text=True).stdout
    rows = list(csv.reader(out.splitlines()))
    header, body = rows[0], rows[1:]
    n = (len(header) - 3) // 3
    data = np.array([[float(c) if c else np.nan for c in r[: 1 + 3 * n]] for r in body])
    return header[1: 1 + n], data, n


def report(names, data, n, at):
    t = data[:, 0]
    before, after = t < at, t > at + 1.0
    lines = []
    for k, name in enumerate(names):
        r = data[:, 1 + k]
        alarm = data[:, 1 + 2 * n + k] > 0.5
        rms = float(np.sqrt(np.mean(r[before] ** 2)))
        change = r[after] - np.mean(r[before])
        snr = float(np.sqrt(np.mean(change ** 2)) / rms) if rms > 0 else float("inf")
        lines.append((name, rms, snr, float(np.mean(alarm[after])), int(np.sum(alarm[before]))))
    return lines


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bgc", default=os.path.join(ROOT, "target", "release", "bgc"))
    p.add_argument("--seconds", type=float, default=1000.0)
    a = p.parse_args()
    at = a.seconds * 0.5125
    with tempfile.TemporaryDirectory() as tmp:
        print("| input | fault | realisation | residual | healthy RMS | fault/noise | "
              "alarms from 1 s after | false alarms before |")
        print("|---|---|---|---|---|---|---|---|")
        for input_name, u in INPUTS.items():
            healthy = os.path.join(tmp, f"{input_name}_healthy.csv")
            simulate(a.bgc, healthy, a.seconds, u, 1)
            for fault_name, fault in FAULTS.items():
                record = os.path.join(tmp, f"{input_name}_{fault_name}.csv")
                simulate(a.bgc, record, a.seconds, u, 2, fault.format(at=at))
                for how, extra in [("integrated", []), ("direct", ["--realise", "direct"])]:
                    names, data, n = residuals(a.bgc, record, healthy, extra)
                    for name, rms, snr, rate, false in report(names, data, n, at):
                        print(f"| {input_name} | {fault_name} | {how} | {name} | {rms:.3g} | "
                              f"{snr:.3g} | {100 * rate:.1f} % | {false} |")
                sys.stdout.flush()


if __name__ == "__main__":
    main()
