#!/usr/bin/env bash
# The EMPS figures of docs/identification.md: identification on the healthy record, then the
# pulse record read with the measured force (healthy) and with the controller's force alone
# (the pulses unmeasured), with the share of pulse and other samples in alarm. Outside CI:
# the records stay out of the repository. Usage: scripts/emps/run.sh [EMPS_DIR] [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
emps="${1:-../shared/data/emps}"
out="${2:-target/emps}"
mkdir -p "$out"
cargo build -q --release -p bgc
bgc=target/release/bgc
model=models/positioning_axis.bg

"$bgc" identify "$model" "$emps/emps_train.csv" --column tau=force \
    --validate "$emps/emps_pulses.csv" -o "$out/emps.params"
cat "$out/emps.params"

"$bgc" residuals "$model" "$emps/emps_pulses.csv" --column tau=force --params "$out/emps.params" \
    --calibrate "$emps/emps_train.csv" --integration-window 20 -o "$out/healthy.csv"
"$bgc" residuals "$model" "$emps/emps_pulses.csv" --column tau=force_ctrl \
    --params "$out/emps.params" --calibrate "$emps/emps_train.csv" --calibrate-column tau=force \
    --integration-window 20 \
    --size-span 0.3 --sizes "$out/sizes.csv" -o "$out/pulses.csv"

python3 - "$emps/emps_pulses.csv" "$out/healthy.csv" "$out/pulses.csv" <<'PY'
import csv
import sys

with open(sys.argv[1]) as f:
    pulse = {round(float(r["t"]), 6): float(r["pulse_v"]) > 0 for r in csv.DictReader(f)}
for path in sys.argv[2:]:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    on = [r["alarm_ARR1"] == "1" for r in rows if pulse.get(round(float(r["t"]), 6), False)]
    off = [r["alarm_ARR1"] == "1" for r in rows if not pulse.get(round(float(r["t"]), 6), False)]
    print(f"{path}: pulse samples in alarm {sum(on) / len(on):.3f} ({len(on)}), "
          f"other samples {sum(off) / len(off):.3f} ({len(off)})")
PY
head -8 "$out/sizes.csv"
