#!/usr/bin/env bash
# Sensor and actuator faults injected into EMPS's real pulse record (read with the measured
# force, where it is healthy), each detected, named and sized by a model whose encoder and
# drive carry them (`with`). Outside CI: the records stay out of the repository.
# Usage: scripts/emps/carried.sh [EMPS_DIR] [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
emps="${1:-../shared/data/emps}"
out="${2:-target/emps-carried}"
mkdir -p "$out"
cargo build -q --release -p bgc
bgc=target/release/bgc

# The shipped model, its drive and encoder given the faults they may carry.
sed -e 's/^Se drive  = tau$/Se drive  = tau with gain = kd, offset = ko/' \
    -e 's/^Dq q on axis "encoder position"/Dq q on axis with bias = qb, gain = qg, drift = qd "encoder position"/' \
    models/positioning_axis.bg > "$out/axis.bg"
cat >> "$out/axis.bg" <<'BG'
param kd = 1 "drive gain"
param ko = 0 [N] "drive offset"
param qb = 0 [m] "encoder bias"
param qg = 1 "encoder gain"
param qd = 0 [m/s] "encoder drift"
BG
"$bgc" identify "$out/axis.bg" "$emps/emps_train.csv" --column tau=force -o "$out/axis.params"

# Each fault from 12 s on: an encoder that reads 10 % more, one that drifts by 1 cm/s, a
# drive that gives 80 % of its command (the record logs the command: force / 0.8), and one
# that gives 10 N less than it is told.
python3 - "$emps/emps_pulses.csv" "$out" <<'PY'
import csv
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
at = 12.0
faults = {
    "encoder_gain": lambda r, t: r.update(q=repr(1.1 * float(r["q"]))),
    "encoder_drift": lambda r, t: r.update(q=repr(float(r["q"]) + 0.01 * (t - at))),
    "drive_gain": lambda r, t: r.update(force=repr(float(r["force"]) / 0.8)),
    "drive_offset": lambda r, t: r.update(force=repr(float(r["force"]) + 10.0)),
}
for name, change in faults.items():
    with open(f"{sys.argv[2]}/{name}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=rows[0].keys())
        w.writeheader()
        for r in rows:
            r = dict(r)
            t = float(r["t"])
            if t >= at:
                change(r, t)
            w.writerow(r)
PY

for fault in encoder_gain encoder_drift drive_gain drive_offset; do
    for span in 5 10; do
        echo "== $fault (truth: gain 1.1, drift 0.01 m/s, gain 0.8, offset -10 N), --size-span $span"
        "$bgc" residuals "$out/axis.bg" "$out/$fault.csv" --column tau=force \
            --params "$out/axis.params" --calibrate "$emps/emps_train.csv" \
            --integration-window 20 --size-span "$span" -o "$out/$fault.residuals.csv" 2>&1 |
            grep -A3 "the fault's size" | cut -c1-200
    done
done
