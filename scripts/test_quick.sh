#!/usr/bin/env bash
# The quick tier: the pure layers' tests (kinematics, models, control, sim engine, bag I/O, wire,
# parameter schemas, architecture; no ROS graph, no browser), about 30-50 s on 2 cores.
# Reuses the venv and install of scripts/setup.sh (runs it only when the venv is missing or its
# requirements changed); the tests import the source tree. Extra arguments go to pytest.
# What is in the tier: QUICK_PATHS in test/conftest.py; a quick test that starts a ROS graph fails.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
VENV=${PX100_VENV:-$ROOT/.venv}
WANT=$(cat "$ROOT/requirements/runtime.txt" "$ROOT/requirements/constraints.txt" | sha256sum | cut -d' ' -f1)
if [ ! -x "$VENV/bin/python" ] || [ "$(cat "$VENV/.px100_requirements.sha" 2>/dev/null)" != "$WANT" ]; then
  bash "$ROOT/scripts/setup.sh"
fi
# the install too when there is one (interface packages), as the full suite sees them
if [ -f "$ROOT/install/setup.bash" ]; then
  # shellcheck disable=SC1091
  PX100_VENV=$VENV source "$ROOT/scripts/env.sh"
else
  # shellcheck disable=SC1091
  source "$VENV/bin/activate"
fi
export ROS_DOMAIN_ID=${PX100_TEST_DOMAIN:-$(( (RANDOM % 90) + 10 ))}
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
unset ROS_LOCALHOST_ONLY
export MPLBACKEND=Agg
cd "$ROOT"
python -m pytest -q -p no:cacheprovider -m quick --durations=10 "$@"
