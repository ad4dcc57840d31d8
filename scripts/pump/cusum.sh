#!/usr/bin/env bash
# The CUSUM's figures of docs/identification.md ("A sequential test beside the threshold"):
# the pump of models/centrifugal_pump.bg from rest, calibrated on one 120-s healthy record
# (seed 1) with and without --cusum; small clogs of the drain at 60 s (seed 3) and the 16
# healthy records of seeds 100-115, monitored with each kept calibration. Outside CI (a few
# minutes). Usage: scripts/pump/cusum.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-target/pump}"
mkdir -p "$out"
cargo build -q --release -p bgc
bgc=target/release/bgc
model=models/centrifugal_pump.bg

"$bgc" simulate "$model" scenarios/pump_healthy.scn -o "$out/healthy.csv"
"$bgc" residuals "$model" "$out/healthy.csv" --calibrate "$out/healthy.csv" \
    --save-calibration "$out/thresholds.cal" -o /dev/null 2>/dev/null
"$bgc" residuals "$model" "$out/healthy.csv" --calibrate "$out/healthy.csv" --cusum \
    --save-calibration "$out/cusum.cal" -o /dev/null 2>/dev/null
for c in 0.999 0.998 0.997; do
    "$bgc" simulate "$model" scenarios/pump_healthy.scn --seed 3 -e "fault c = $c*c at 60" \
        -o "$out/clog$c.csv"
    for how in thresholds cusum; do
        "$bgc" residuals "$model" "$out/clog$c.csv" --calibration "$out/$how.cal" --no-size \
            -o "$out/clog$c-$how.csv" 2>/dev/null
    done
done
for seed in $(seq 100 115); do
    "$bgc" simulate "$model" scenarios/pump_healthy.scn --seed "$seed" -o "$out/h$seed.csv"
    for how in thresholds cusum; do
        "$bgc" residuals "$model" "$out/h$seed.csv" --calibration "$out/$how.cal" --no-size \
            -o "$out/h$seed-$how.csv" 2>/dev/null
    done
done

python3 - "$out" <<'PY'
import csv
import sys

out = sys.argv[1]
arrs = ["ARR1", "ARR2", "ARR3"]


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


print("clog   shift/threshold  how         first alarm  ARR3 in alarm from 61 s  episode")
for c in ["0.999", "0.998", "0.997"]:
    for how in ["thresholds", "cusum"]:
        rows = read(f"{out}/clog{c}-{how}.csv")
        after = [r for r in rows if float(r["t"]) >= 61.0]
        shift = sum(float(r["ARR3"]) for r in after) / len(after) / float(after[-1]["threshold_ARR3"])
        first = next((float(r["t"]) for r in rows if r["alarm_ARR3"] == "1"), None)
        share = sum(r["alarm_ARR3"] == "1" for r in after) / len(after)
        print(f"{c}  {abs(shift):.2f}  {how:10}  {first}  {100 * share:.1f} %  {rows[-1]['episode']}")
for how in ["thresholds", "cusum"]:
    alarmed = []
    for seed in range(100, 116):
        rows = read(f"{out}/h{seed}-{how}.csv")
        on = [sum(r[f"alarm_{a}"] == "1" for r in rows) for a in arrs]
        if any(on):
            alarmed.append((seed, on))
    print(f"{how}: healthy records with any alarm: {len(alarmed)} of 16 {alarmed}")
PY
