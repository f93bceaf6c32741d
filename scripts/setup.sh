#!/usr/bin/env bash
# Set up px100_control from nothing but Python 3.11/3.12 and the package registries:
# a venv with pinned ROS 2 Jazzy wheels (rclpy, common_interfaces), numpy, yourdfpy, mcap, colcon,
# then `colcon build` into <repo>/install. Idempotent: re-running only rebuilds the package.
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
echo "[setup] colcon build"
cd "$ROOT"
# shellcheck disable=SC1091
source "$VENV/bin/activate"
export AMENT_PREFIX_PATH="$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
colcon --log-base "$ROOT/log" build --paths "$ROOT" --build-base "$ROOT/build" \
  --install-base "$ROOT/install" \
  >"$ROOT/.colcon_build.txt" 2>&1 || { cat "$ROOT/.colcon_build.txt"; exit 1; }
echo "[setup] done: install prefix $ROOT/install"
