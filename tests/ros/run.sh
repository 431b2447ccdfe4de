#!/usr/bin/env bash
# The tests over DDS: our executables and an rclpy peer, against the ROS 2
# that scripts/ros2-jazzy.sh set up (run it first). Each test picks its own
# ROS_DOMAIN_ID.
#
#   tests/ros/run.sh                 all of them, then hold_sweep.py's grid
#   tests/ros/run.sh --only A,B      tests/ros/A.py and B.py alone
#   tests/ros/run.sh --skip A,B      all but tests/ros/A.py and B.py, then the grid
set -euo pipefail
cd "$(dirname "$0")/../.."
mode=${1:-all}
IFS=, read -r -a names <<<"${2:-}"
case "$mode" in
  all) ;;
  --only | --skip)
    [ "${#names[@]}" -gt 0 ] || { echo "run.sh: $mode needs test names" >&2; exit 2; }
    for name in "${names[@]}"; do
      [ -f "tests/ros/$name.py" ] || { echo "run.sh: no test tests/ros/$name.py" >&2; exit 2; }
    done ;;
  *) echo "usage: tests/ros/run.sh [--only A,B | --skip A,B]" >&2; exit 2 ;;
esac
# True when tests/ros/$1.py is one of the names given.
named() { local n; for n in "${names[@]}"; do [ "$n" = "$1" ] && return 0; done; return 1; }
# shellcheck disable=SC1091
. "${CARGO_TARGET_DIR:-target}/ros2/env.sh"
# The independent plant of hold_sweep.py: MuJoCo and example-robot-data's
# UR5; the MCAP reader and writer of test_replay_over_dds.py: Python's mcap
# (pinned), into the ROS venv that runs the rclpy peer.
if ! python -c 'import mujoco, mcap' 2>/dev/null ||
  ! python -m pip show --quiet example-robot-data >/dev/null 2>&1; then
  _ROS_WHEELS_BOOTSTRAP_COMPLETE=1 python -m pip install --quiet --disable-pip-version-check \
    "mujoco==4.0.0" "example-robot-data==6.0.0" "mcap==1.6.0"
fi
status=0
# Runs one test script with its arguments, then says how long it took.
timed() {
  echo "== $*"
  local start=$SECONDS
  python "$@" || status=1
  echo "== $1: $((SECONDS - start)) s"
}
if [ "$mode" = --only ]; then
  for name in "${names[@]}"; do timed "tests/ros/$name.py"; done
  exit "$status"
fi
for t in tests/ros/test_*.py; do
  [ "$mode" = --skip ] && named "$(basename "$t" .py)" && continue
  timed "$t"
done
# Both moves with the shipped parameters, nothing declared, on an arm with
# an 8 ms command cycle and bodies the controller is not told about, on our
# simulator and on MuJoCo's UR5.
timed tests/ros/hold_sweep.py --grid ci
exit "$status"
