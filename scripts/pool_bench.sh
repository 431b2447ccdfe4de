#!/usr/bin/env bash
# Adapted against pooled (`adapt`'s two candidates) on simulated units, as
# docs/results.md reports it. The base: unit 1, sessions 1 and 2 (`collect
# --trials 1`: 16000 rows), fx and fz, the default options. Each new unit
# U = 2..5 gives 80 s (session 2) in two ways: all four sets, and its z and
# combined pushes only (sets 3 and 4). For each: the cross-validated scores
# of both candidates, the one chosen, and the fx / fz
# RMSE on another session of the unit (session 3, all sets) of the base,
# the adapted model alone (`--no-pool`) and the chosen one.
#
#   scripts/pool_bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/bench-pool
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/tactile_force
c() { "$bin" collect --unit "$1" --seed "$2" --trials 1 --out "$out/u$1s$2.csv" >/dev/null; }
c 1 1; c 1 2
"$bin" train --data "$out/u1s1.csv,$out/u1s2.csv" --axes fx,fz --out "$out/base.json" >/dev/null
rmse() { "$bin" eval --model "$1" --test "$2" --json | tail -1 |
  python3 -c 'import json,sys; r=json.load(sys.stdin)["gp"]["rmse"]; print("%.3f / %.3f" % (r["fx"], r["fz"]))'; }
echo "| unit | new data | cross-validated score adapted / pooled | chosen | fx / fz RMSE (N), another session: base | adapted | chosen |"
echo "|---|---|---|---|---|---|---|"
for u in 2 3 4 5; do
  c "$u" 2; c "$u" 3
  python3 - "$out/u${u}s2.csv" "$out/u${u}_z.csv" <<'PY'
import sys
lines = open(sys.argv[1]).read().splitlines()
k = lines[0].split(",").index("set")
kept = [l for l in lines[1:] if l.split(",")[k] in ("3", "4")]
open(sys.argv[2], "w").write("\n".join([lines[0]] + kept) + "\n")
PY
  for kind in all z; do
    data="$out/u${u}s2.csv"; label="80 s, all sets"
    if [ "$kind" = z ]; then data="$out/u${u}_z.csv"; label="40 s, z + combined"; fi
    said=$("$bin" adapt --model "$out/base.json" --data "$data" --out "$out/pool.json")
    "$bin" adapt --model "$out/base.json" --data "$data" --no-pool --out "$out/adapted.json" >/dev/null
    scores=$(echo "$said" | grep -E '^  (adapted|pooled) ' | sed -E 's/.*\(([0-9.]+)\).*/\1/' | paste -sd/ | sed 's#/# / #')
    chosen=$(echo "$said" | grep -q '^pooled from ' && echo pooled || echo adapted)
    test="$out/u${u}s3.csv"
    echo "| $u | $label | $scores | $chosen | $(rmse "$out/base.json" "$test") | $(rmse "$out/adapted.json" "$test") | $(rmse "$out/pool.json" "$test") |"
  done
done
