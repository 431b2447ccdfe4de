#!/usr/bin/env bash
# The tests over DDS: our executables and an rclpy peer, against the ROS 2
# that scripts/ros2-jazzy.sh set up (run it first). Each test picks its own
# ROS_DOMAIN_ID.
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck disable=SC1091
. "${CARGO_TARGET_DIR:-target}/ros2/env.sh"
status=0
for t in tests/ros/test_*.py; do
  echo "== $t"
  python "$t" || status=1
done
exit "$status"
