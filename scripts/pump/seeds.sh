#!/usr/bin/env bash
# The pump's figures of docs/identification.md ("A record that starts at rest"): the pump of
# models/centrifugal_pump.bg started from rest, calibrated on one 120-s healthy record (seed
# 1), its drain clogged to 60 % at 60 s on another (seed 2), and 16 healthy records of other
# seeds (100-115) monitored with the kept calibration: the samples in alarm of each ARR and
# the largest |r|/threshold on each. Outside CI (about a minute and a half).
# Usage: scripts/pump/seeds.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-target/pump}"
mkdir -p "$out"
cargo build -q --release -p bgc
bgc=target/release/bgc
model=models/centrifugal_pump.bg

"$bgc" simulate "$model" scenarios/pump_healthy.scn -o "$out/healthy.csv"
"$bgc" simulate "$model" scenarios/pump_clog.scn -o "$out/clog.csv"
"$bgc" residuals "$model" "$out/clog.csv" --calibrate "$out/healthy.csv" \
    --save-calibration "$out/pump.cal" -o "$out/clog-r.csv"
grep '^arr' "$out/pump.cal"
for seed in $(seq 100 115); do
    "$bgc" simulate "$model" scenarios/pump_healthy.scn --seed "$seed" -o "$out/h$seed.csv"
    "$bgc" residuals "$model" "$out/h$seed.csv" --calibration "$out/pump.cal" \
        -o "$out/h$seed-r.csv" 2>/dev/null
done

python3 - "$out" <<'PY'
import csv
import sys

out = sys.argv[1]
arrs = ["ARR1", "ARR2", "ARR3"]


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


rows = read(f"{out}/clog-r.csv")
first = next((float(r["t"]) for r in rows if any(r[f"alarm_{a}"] == "1" for a in arrs)), None)
after = [r for r in rows if float(r["t"]) >= 61.0]
share = sum(r["alarm_ARR3"] == "1" for r in after) / len(after)
print(f"clog at 60 s: first alarm at {first} s, ARR3 in alarm on {100 * share:.1f} % of the "
      f"samples from 61 s, episode `{rows[-1]['episode']}`, {rows[-1]['sized']} = {rows[-1]['size']}")
print("seed  samples in alarm (ARR1 ARR2 ARR3)  largest |r|/threshold")
records = 0
for seed in range(100, 116):
    rows = read(f"{out}/h{seed}-r.csv")
    on = [sum(r[f"alarm_{a}"] == "1" for r in rows) for a in arrs]
    worst = [max(abs(float(r[a])) / float(r[f"threshold_{a}"]) for r in rows
                 if r[a] and r[f"threshold_{a}"]) for a in arrs]
    records += any(on)
    print(f"{seed}   {on}   {' '.join(f'{w:.2f}' for w in worst)}")
print(f"healthy records with any alarm: {records} of 16")
PY
