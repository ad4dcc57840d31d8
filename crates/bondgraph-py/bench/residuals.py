"""Residuals from Python on a 10^6-row DataFrame: rows and samples per second, the best of 15 runs.

Method: the backlash bench compiled as `bgc models/backlash_bench.bg` does (ARRs
integrated once where that lowers their order), Savitzky-Golay estimates over 11 samples of
degree 3, a threshold on each residual; the record is the one the Rust generator's criterion
bench (`cargo bench -p bondgraph --bench residuals -- residual_generator`) uses, sin t,
cos 1.3t and sin 0.7t at a 1 ms step, here 10^6 rows in a pandas DataFrame. The time
counted is the whole `model.residuals(frame)` call: reading the columns, the pass, and the
arrays and tables handed back.

Each run is timed by the wall clock and by the process's CPU time; on a shared machine the
second varies less. The figure to set beside it is the generated Rust's on the same waves,
`residual_generator/integrated_savitzky_golay_11`, and the interpreter's alone,
`cargo bench -p bondgraph-interpreter --bench generator`: run them in the same sitting.

    python crates/bondgraph-py/bench/residuals.py [ROWS] [RUNS]
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
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 15
    model = bgc.compile(ROOT / "models" / "backlash_bench.bg")
    t = np.arange(rows) * 1e-3
    waves = [np.sin(t), np.cos(1.3 * t), np.sin(0.7 * t)]
    frame = pd.DataFrame({"t": t, **dict(zip(model.signals, waves))})
    wall = cpu = float("inf")
    for _ in range(runs):
        start, start_cpu = time.perf_counter(), time.process_time()
        run = model.residuals(frame, thresholds=1.0)
        wall = min(wall, time.perf_counter() - start)
        cpu = min(cpu, time.process_time() - start_cpu)
    signals = len(model.signals)
    print(f"{rows} rows of {signals} signals, {len(run)} estimates of {', '.join(run.names)}; best of {runs}:")
    for name, best in (("wall clock", wall), ("CPU time", cpu)):
        print(f"  {name}: {best * 1e3:.1f} ms, {rows / best / 1e6:.2f} million rows/s, "
              f"{rows * signals / best / 1e6:.1f} million samples/s")


if __name__ == "__main__":
    main()
