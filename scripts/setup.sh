#!/usr/bin/env bash
# Set up px100_control from nothing but Python 3.11/3.12 and the package registries:
# a venv with pinned ROS 2 Jazzy wheels (rclpy, common_interfaces), numpy, yourdfpy, mcap, colcon,
# the interface packages of interfaces/ the environment lacks, then `colcon build` into
# <repo>/install. Idempotent: a re-run on an unchanged tree rebuilds nothing.
# Afterwards: `source scripts/env.sh` gives a shell where `ros2 run`-style paths resolve.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
VENV=${PX100_VENV:-$ROOT/.venv}
if [ -z "${PYTHON:-}" ]; then
  for cand in python3.11 python3.12 python3; do
    if command -v "$cand" >/dev/null 2>&1; then PYTHON=$cand; break; fi
  done
fi
# Serialise concurrent setups of the same tree (parallel test runs share venv and install/).
exec 9>"$ROOT/.setup.lock"
flock 9
STAMP="$VENV/.px100_requirements.sha"
WANT=$(cat "$ROOT/requirements/runtime.txt" "$ROOT/requirements/constraints.txt" | sha256sum | cut -d' ' -f1)
if [ ! -x "$VENV/bin/python" ]; then
  echo "[setup] creating venv $VENV with $PYTHON"
  "$PYTHON" -m venv "$VENV"
fi
if [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
  echo "[setup] installing pinned dependencies (about a minute on a fresh machine)"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check \
    -r "$ROOT/requirements/runtime.txt" -c "$ROOT/requirements/constraints.txt"
  echo "$WANT" > "$STAMP"
fi
cd "$ROOT"
# shellcheck disable=SC1091
source "$VENV/bin/activate"
export AMENT_PREFIX_PATH="$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# Interface packages (interfaces/): build those the environment lacks. A ROS 2 install sourced
# before this script (apt) that has one keeps its own; the rest are generated and compiled from
# the wheels once, and reused while interfaces/, the pins and the interpreter are unchanged.
IFACE_PATHS=()
for pkg_dir in "$ROOT"/interfaces/*/; do
  pkg=$(basename "$pkg_dir")
  [ -f "$pkg_dir/package.xml" ] || continue
  provided=
  IFS=: read -ra prefixes <<< "${AMENT_PREFIX_PATH:-}"
  for prefix in "${prefixes[@]}"; do
    case $prefix in "$ROOT/install"|"$ROOT/install/"*) continue ;; esac
    if [ -e "$prefix/share/ament_index/resource_index/packages/$pkg" ]; then provided=$prefix; fi
  done
  if [ -n "$provided" ]; then
    echo "[setup] $pkg: using the environment's ($provided)"
  else
    IFACE_PATHS+=("$pkg_dir")
  fi
done
IFACE_STAMP="$ROOT/install/.px100_interfaces.sha"
# (what the build depends on: the ROS/colcon pins, the packages built, the interpreter, the sources)
IFACE_WANT=$( { grep -iE '^(ros|rosidl|ament|colcon|rcl|rmw)[-_]' "$ROOT/requirements/constraints.txt";
                echo "$(for d in "${IFACE_PATHS[@]}"; do basename "$d"; done) $("$VENV/bin/python" -VV)";
                find "$ROOT/interfaces" -type f | LC_ALL=C sort | xargs cat; } | sha256sum | cut -d' ' -f1)
CMAKE_ARGS=(-DBUILD_TESTING=OFF "-DCMAKE_PROJECT_INCLUDE=$ROOT/interfaces/cmake/wheel_python_includes.cmake")
if [ ${#IFACE_PATHS[@]} -gt 0 ] && [ "$(cat "$IFACE_STAMP" 2>/dev/null)" != "$IFACE_WANT" ]; then
  echo "[setup] building interface packages: $(for d in "${IFACE_PATHS[@]}"; do basename "$d"; done | tr '\n' ' ')(3-5 min on a fresh machine)"
  rm -f "$IFACE_STAMP"
  colcon --log-base "$ROOT/log" build --paths "${IFACE_PATHS[@]}" --build-base "$ROOT/build" \
    --install-base "$ROOT/install" --executor sequential --cmake-args "${CMAKE_ARGS[@]}" \
    >"$ROOT/.colcon_interfaces.txt" 2>&1 || { tail -60 "$ROOT/.colcon_interfaces.txt"; exit 1; }
  echo "$IFACE_WANT" > "$IFACE_STAMP"
fi
# The Python package: rebuilt when a file colcon installs may have changed.
PKG_STAMP="$ROOT/install/.px100_package.sha"
PKG_WANT=$( { echo "$IFACE_WANT"; cd "$ROOT" && find package.xml setup.py setup.cfg colcon.pkg \
               px100_control resource urdf config launch environment scripts -type f \
               -not -name '*.pyc' 2>/dev/null | LC_ALL=C sort | xargs cat; } | sha256sum | cut -d' ' -f1)
if [ "$(cat "$PKG_STAMP" 2>/dev/null)" != "$PKG_WANT" ] || [ ! -f "$ROOT/install/setup.bash" ]; then
  echo "[setup] colcon build"
  rm -f "$PKG_STAMP"
  colcon --log-base "$ROOT/log" build --paths "$ROOT" --build-base "$ROOT/build" \
    --install-base "$ROOT/install" \
    >"$ROOT/.colcon_build.txt" 2>&1 || { cat "$ROOT/.colcon_build.txt"; exit 1; }
  echo "$PKG_WANT" > "$PKG_STAMP"
fi
echo "[setup] done: install prefix $ROOT/install"
