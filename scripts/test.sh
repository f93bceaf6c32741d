#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the whole test suite in a private DDS domain.
# Extra arguments go to pytest, e.g. `bash scripts/test.sh -k kinematics`.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/scripts/setup.sh"
bash "$ROOT/scripts/setup_browser.sh"
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
# Parallel workers (pytest-xdist): PX100_TEST_WORKERS of them, default 2 (0: one process).
# Worker K runs in DDS domain ROS_DOMAIN_ID + K with its own viewer ports (test/conftest.py);
# a test module goes to one worker whole, except SPREAD_MODULES (test/tiers.py).
WORKERS=${PX100_TEST_WORKERS:-2}
# a domain no other ROS program on this host is using (scripts/free_domain.py says how it knows)
DOMAINS=$(( WORKERS > 0 ? WORKERS : 1 ))
ROS_DOMAIN_ID=${PX100_TEST_DOMAIN:-$(python "$ROOT/scripts/free_domain.py" "$DOMAINS")}
export ROS_DOMAIN_ID
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
unset ROS_LOCALHOST_ONLY
export MPLBACKEND=Agg
cd "$ROOT"
if [ "$WORKERS" -gt 0 ]; then
  echo "[test] $WORKERS workers, ROS_DOMAIN_ID=$ROS_DOMAIN_ID..$(( ROS_DOMAIN_ID + WORKERS - 1 ))"
  set -- -n "$WORKERS" "$@"
else
  echo "[test] ROS_DOMAIN_ID=$ROS_DOMAIN_ID"
fi
# Reruns are opt-in: PX100_RERUNS=2 retries a failed test up to twice (listed in the summary as
# "rerun", their first failures in out/reruns.log); by default a failure is a failure.
RERUNS=${PX100_RERUNS:-0}
if [ "$RERUNS" -gt 0 ]; then
  set -- --reruns "$RERUNS" --reruns-delay 1 "$@"
fi
# the slowest 20 tests and their times close every run (--durations=20)
python -m pytest -q -rfER -p no:cacheprovider --durations=20 "$@"
