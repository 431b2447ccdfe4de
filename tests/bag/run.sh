#!/usr/bin/env bash
# learn::data::bag and learn::data::ros1 against bags from independent
# writers: a short simulated session (collect) written as rosbag2-style MCAP
# files by Python's mcap and mcap-ros2-support (tests/bag/write_bags.py),
# and hands' BioTac messages written as ROS 1 bags and rosbag2 MCAP by
# Python's rosbags (tests/bag/write_hand_bags.py); then read by the ignored
# tests of tests/mcap_bags.rs and tests/hand_bags.rs. The venv is cached
# under the target dir.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"
venv="$target/bag-venv"
if ! "$venv/bin/python" -c 'import mcap_ros2.writer, rosbags.rosbag1' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet mcap mcap-ros2-support rosbags
fi

out="$target/test-bags"
rm -rf "$out"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
# One trial per set: 4 trials of 20 s, 8000 rows.
cargo run --release -- collect --trials 1 --out "$out/session.csv"
"$venv/bin/python" tests/bag/write_bags.py "$out/session.csv" msg/msg/BioTac.msg "$out"
"$venv/bin/python" tests/bag/write_hand_bags.py "$out"
TACTILE_FORCE_TEST_BAGS="$out" cargo test --release --test mcap_bags --test hand_bags -- --ignored
