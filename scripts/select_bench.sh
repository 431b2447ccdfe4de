#!/usr/bin/env bash
# `train --select` on 20000 rows of electrode-only data (19 electrodes, fx, fy,
# fz), as docs/results.md reports it: five simulated sessions of unit 1
# (collect --seed 1..5, one trial per set each), every second row (50 Hz),
# each session's trials numbered by its seed (5 trials per set: 5 folds), the
# PDC, PAC, TDC and TAC columns dropped. Prints the table and the process's
# wall and CPU time.
#
#   scripts/select_bench.sh [EXTRA train ARGS...]
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/bench-select
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/tactile_force
for s in 1 2 3 4 5; do
  "$bin" collect --trials 1 --seed "$s" --out "$out/s$s.csv" >/dev/null
done
python3 - "$out" <<'PY'
import csv, sys
out = sys.argv[1]
keep = ["t", "set", "trial"] + [f"e{i}" for i in range(1, 20)] + ["fx", "fy", "fz"]
with open(f"{out}/electrodes_20k.csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(keep)
    for s in range(1, 6):
        with open(f"{out}/s{s}.csv") as g:
            r = csv.DictReader(g)
            for i, row in enumerate(r):
                if i % 2 == 0:
                    row["trial"] = str(s)
                    w.writerow([row[k] for k in keep])
PY
/usr/bin/time -f "wall %e s, user %U s, system %S s" \
  "$bin" train --select --data "$out/electrodes_20k.csv" --tare-samples 25 --out "$out/selected.json" "$@"
