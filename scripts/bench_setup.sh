#!/usr/bin/env bash
# Create (idempotently) the separate benchmark venv with the IK peers of
# benchmarks/bench_kinematics.py: modern_robotics, ikpy, roboticstoolbox-python and, if it
# installs, pinocchio (pip name `pin`). It is NOT the runtime venv: no system site packages.
# Usage: bash scripts/bench_setup.sh            (venv at ${PX100_BENCH_VENV:-/tmp/pxvenv/bench})
# Then:  $PX100_BENCH_VENV/bin/python benchmarks/bench_kinematics.py [--quick] [--robot px100]
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
VENV=${PX100_BENCH_VENV:-/tmp/pxvenv/bench}
PYTHON=${PYTHON:-python3}
mkdir -p "$(dirname "$VENV")"
exec 9>"$VENV.lock"
flock 9
STAMP="$VENV/.bench_requirements.sha"
WANT=$(sha256sum "$ROOT/requirements/bench.txt" | cut -d' ' -f1)
if [ ! -x "$VENV/bin/python" ]; then
  echo "[bench_setup] creating venv $VENV with $PYTHON"
  "$PYTHON" -m venv "$VENV"
fi
if [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
  echo "[bench_setup] installing requirements/bench.txt (a few minutes on a fresh machine)"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$ROOT/requirements/bench.txt"
  if "$VENV/bin/python" -m pip install -q --disable-pip-version-check pin; then
    echo "[bench_setup] pinocchio (pin) installed"
  else
    echo "[bench_setup] pinocchio (pin) did not install: its column will be skipped"
  fi
  echo "$WANT" > "$STAMP"
fi
"$VENV/bin/python" - <<'PY'
import importlib
for name in ('modern_robotics', 'ikpy', 'roboticstoolbox', 'pinocchio'):
    try:
        mod = importlib.import_module(name)
        print(f'[bench_setup] {name} {getattr(mod, "__version__", "")}')
    except Exception as exc:  # noqa: BLE001
        print(f'[bench_setup] {name} unavailable: {type(exc).__name__}: {exc}')
PY
echo "[bench_setup] done: $VENV"
