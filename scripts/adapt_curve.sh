#!/usr/bin/env bash
# Calibrating a new sensor unit: RMSE against seconds of its data, adapted
# from a base model against trained from scratch (simulated units).
#
# Base: unit 1, session 1 (800 s). New unit: unit 2; its short recording is
# session 2 with one trial per set (80 s), cut to the first T/4 s of each of
# its four trials for T = 10, 20, 40, 80 s; test: unit 2, session 3 (800 s).
# Prints one row per T with fx/fy/fz RMSE (N) and the adapt time.
# Usage: scripts/adapt_curve.sh [work dir]   (about 3 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-target/adapt-curve}"
mkdir -p "$work"
cargo build --release --quiet
tf=target/release/tactile_force
$tf collect --unit 1 --seed 1 --out "$work/base.csv" >/dev/null
$tf collect --unit 2 --seed 2 --trials 1 --out "$work/new80.csv" >/dev/null
$tf collect --unit 2 --seed 3 --out "$work/test.csv" >/dev/null
$tf train --data "$work/base.csv" --out "$work/base.json" >/dev/null
rmse() { # model -> "fx fy fz" RMSE of the GP on the test session
  $tf eval --model "$1" --test "$work/test.csv" | awk '$1 == "overall" { print $3, $5, $7 }'
}
echo "base (unit 1) on unit 2: $(rmse "$work/base.json")"
printf '%6s  %-26s  %-26s  %s\n' "new s" "adapted fx fy fz (N)" "from scratch fx fy fz (N)" "adapt s"
for secs in 10 20 40 80; do
  cut="$work/cut$secs.csv"
  # The first secs/4 s of each trial (t is the time since the trial's start).
  awk -F, -v s="$secs" 'NR == 1 || $1 < s / 4 - 1e-9' "$work/new80.csv" >"$cut"
  # --no-pool: the adapted model alone (pool_bench.sh compares it with pooling).
  took=$($tf adapt --model "$work/base.json" --data "$cut" --no-pool --out "$work/adapted$secs.json" | tail -1 |
    sed -E 's/.* in ([0-9.]+) s;.*/\1/')
  $tf train --data "$cut" --out "$work/scratch$secs.json" >/dev/null
  printf '%6s  %-26s  %-26s  %s\n' "$secs" "$(rmse "$work/adapted$secs.json")" \
    "$(rmse "$work/scratch$secs.json")" "$took"
done
