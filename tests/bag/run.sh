#!/usr/bin/env bash
# learn::bag against bags from an independent writer: a short simulated
# session (collect) written as rosbag2-style MCAP files by Python's mcap and
# mcap-ros2-support (tests/bag/write_bags.py), then read by the ignored
# tests of tests/mcap_bags.rs. The venv is cached under the target dir.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"
venv="$target/bag-venv"
if ! "$venv/bin/python" -c 'import mcap_ros2.writer' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet mcap mcap-ros2-support
fi

out="$target/test-bags"
rm -rf "$out"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
# The shipped protocol with one trial per set (4 trials of 20 s, 8000 rows).
sed 's/^  trials_per_set: 10$/  trials_per_set: 1/' config/biotac_sim.yaml >"$out/short.yaml"
if ! grep -q '^  trials_per_set: 1$' "$out/short.yaml"; then
  echo "tests/bag/run.sh: config/biotac_sim.yaml changed; update the sed line" >&2
  exit 1
fi
cargo run --release -- collect --config "$out/short.yaml" --out "$out/session.csv"
"$venv/bin/python" tests/bag/write_bags.py "$out/session.csv" msg/msg/BioTac.msg "$out"
TACTILE_FORCE_TEST_BAGS="$out" cargo test --release --test mcap_bags -- --ignored
