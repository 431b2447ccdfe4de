#!/usr/bin/env bash
# learn::data::bag and learn::data::ros1 against bags from independent
# writers: a short simulated session (collect) written as rosbag2-style MCAP
# files by Python's mcap and mcap-ros2-support (tests/bag/write_bags.py),
# and hands' BioTac messages written as ROS 1 bags and rosbag2 MCAP by
# Python's rosbags (tests/bag/write_hand_bags.py); then read by the ignored
# tests of tests/mcap_bags.rs and tests/hand_bags.rs. And the other way
# round: a calibration killed (SIGKILL) at 40 % of its motion, its session
# read by Python's mcap (tests/bag/read_cut.py) as far as our reader reads
# it. The venv is cached
# under the target dir.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"
venv="$target/bag-venv"
if ! "$venv/bin/python" -c 'import mcap_ros2.writer, rosbags.rosbag1' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet mcap mcap-ros2-support rosbags
fi
# `--venv-only`: the venv and nothing else (.ci/run makes it beside the build).
[ "${1:-}" = "--venv-only" ] && exit 0

out="$target/test-bags"
rm -rf "$out"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
# One trial per set: 4 trials of 20 s, 8000 rows.
cargo run --release -- collect --trials 1 --out "$out/session.csv"
"$venv/bin/python" tests/bag/write_bags.py "$out/session.csv" msg/msg/BioTac.msg "$out"
"$venv/bin/python" tests/bag/write_hand_bags.py "$out"
# The calibration's motion on unit 2 takes 76.1 s (--realtime paces it);
# its session file appears as the arm starts.
cargo build --release
bin="$target/release/tactile_force"
"$bin" demo calibrate --unit 2 --realtime --out "$out/cut-model.json" \
  --session "$out/cut.mcap" >/dev/null 2>&1 &
pid=$!
for _ in $(seq 1 6000); do [ -e "$out/cut.mcap" ] && break; sleep 0.02; done
sleep 30.4
kill -KILL "$pid"
wait "$pid" || true
"$venv/bin/python" tests/bag/read_cut.py "$out/cut.mcap" > "$out/cut.json"
cat "$out/cut.json"
TACTILE_FORCE_TEST_BAGS="$out" cargo test --release --test mcap_bags --test hand_bags -- --ignored
