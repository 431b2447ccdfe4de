#!/usr/bin/env bash
# Our kinematics against an independent library: Pinocchio (`pin`) on the
# robot descriptions of example-robot-data and ours, both from PyPI into a
# venv cached under the target dir (tests/kinematics/check_pinocchio.py);
# then the BioTac mount model (config/biotac_mount.urdf.xacro, expanded by
# ROS's xacro from PyPI) against each shipped robot's tool parameters
# (tests/kinematics/check_biotac_mount.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"
venv="$target/kin-venv"
if ! "$venv/bin/python" -c 'import pinocchio, xacro' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet "pin==4.1.0" "example-robot-data==6.0.0" "xacro==2.1.1"
fi
# `--venv-only`: the venv and nothing else (.ci/run makes it beside the build).
[ "${1:-}" = "--venv-only" ] && exit 0
robots=$("$venv/bin/python" -c 'import sys, os; print(os.path.join(sys.prefix, "lib", "python%d.%d" % sys.version_info[:2], "site-packages", "cmeel.prefix", "share", "example-robot-data", "robots"))')
cargo build --release --bin tactile_force
"$venv/bin/python" tests/kinematics/check_pinocchio.py "$target/release/tactile_force" "$robots"
"$venv/bin/python" tests/kinematics/check_biotac_mount.py
