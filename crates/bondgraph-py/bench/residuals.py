"""Residuals from Python on a 10^6-row DataFrame: samples per second, the best of five runs.

Method: the backlash bench compiled as `bgc models/backlash_bench.bg` does (ARRs
integrated once where that lowers their order), Savitzky-Golay estimates over 11 samples of
degree 3, a threshold on each residual; the record is the one the Rust generator's criterion
bench (`cargo bench -p bondgraph --bench residuals -- residual_generator`) uses, sin t,
cos 1.3t and sin 0.7t at a 1 ms step, here 10^6 rows in a pandas DataFrame. The time
counted is the whole `model.residuals(frame)` call: reading the columns, the pass, and the
arrays and tables handed back.

    python crates/bondgraph-py/bench/residuals.py [ROWS]
"""

import pathlib
import sys
import time

import numpy as np
import pandas as pd

import bondgraph_compiler as bgc

ROOT = pathlib.Path(__file__).resolve().parents[3]


def main() -> None:
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    model = bgc.compile(ROOT / "models" / "backlash_bench.bg")
    t = np.arange(rows) * 1e-3
    waves = [np.sin(t), np.cos(1.3 * t), np.sin(0.7 * t)]
    frame = pd.DataFrame({"t": t, **dict(zip(model.signals, waves))})
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        run = model.residuals(frame, thresholds=1.0)
        best = min(best, time.perf_counter() - start)
    print(f"{rows} rows, {len(run)} estimates of {', '.join(run.names)}: "
          f"best of 5 {best * 1e3:.1f} ms, {rows / best / 1e6:.1f} million rows/s")


if __name__ == "__main__":
    main()
