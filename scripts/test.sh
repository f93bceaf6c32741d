#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the whole test suite in a private DDS domain.
# Extra arguments go to pytest, e.g. `bash scripts/test.sh -k kinematics`.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/scripts/setup.sh"
bash "$ROOT/scripts/setup_browser.sh"
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
# Parallel workers (pytest-xdist): PX100_TEST_WORKERS of them, default 3 (0: one process;
# benchmarks/README.md says why 3).
# Without arguments the stress package runs after the parallel phase, alone (see below); with
# arguments, one pytest run with them.
# Worker K runs in DDS domain ROS_DOMAIN_ID + K with its own viewer ports (test/conftest.py);
# a test module goes to one worker whole, except SPREAD_MODULES (test/tiers.py).
WORKERS=${PX100_TEST_WORKERS:-3}
# a domain no other ROS program on this host is using (scripts/free_domain.py says how it knows)
DOMAINS=$(( WORKERS > 0 ? WORKERS : 1 ))
ROS_DOMAIN_ID=${PX100_TEST_DOMAIN:-$(python "$ROOT/scripts/free_domain.py" "$DOMAINS")}
export ROS_DOMAIN_ID
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
unset ROS_LOCALHOST_ONLY
export MPLBACKEND=Agg
cd "$ROOT"
# Reruns are opt-in: PX100_RERUNS=2 retries a failed test up to twice (listed in the summary as
# "rerun", their first failures in out/reruns.log); by default a failure is a failure.
RERUNS=${PX100_RERUNS:-0}
RERUN_ARGS=()
if [ "$RERUNS" -gt 0 ]; then
  RERUN_ARGS=(--reruns "$RERUNS" --reruns-delay 1)
fi
PYTEST=(python -m pytest -q -rfER -p no:cacheprovider --durations=20 "${RERUN_ARGS[@]}")
if [ "$WORKERS" -gt 0 ] && [ $# -eq 0 ]; then
  # Two phases: everything but the stress package on the workers, then the stress package
  # (test/stress: timing bounds under injected faults and load, which assume the machine is
  # its own) in one process. The slowest 20 tests of both phases close the run, then the 20
  # modules that cost the most CPU.
  # each test's CPU (test/conftest.py writes out/cpu/<worker>.jsonl): this run's only
  rm -rf out/cpu
  mkdir -p out
  echo "[test] phase 1 of 2: $WORKERS workers, ROS_DOMAIN_ID=$ROS_DOMAIN_ID..$(( ROS_DOMAIN_ID + WORKERS - 1 )), all but the stress tests"
  status=0
  "${PYTEST[@]}" -n "$WORKERS" -m "not stress" --junitxml=out/junit_parallel.xml || status=$?
  echo "[test] phase 2 of 2: the stress tests (test/stress), one process, ROS_DOMAIN_ID=$ROS_DOMAIN_ID"
  stress_status=0
  "${PYTEST[@]}" -m stress --junitxml=out/junit_stress.xml || stress_status=$?
  python scripts/slowest_tests.py --cpu out/cpu out/junit_parallel.xml out/junit_stress.xml
  exit $(( status != 0 ? status : stress_status ))
fi
if [ "$WORKERS" -gt 0 ]; then
  echo "[test] $WORKERS workers, ROS_DOMAIN_ID=$ROS_DOMAIN_ID..$(( ROS_DOMAIN_ID + WORKERS - 1 ))"
  set -- -n "$WORKERS" "$@"
else
  echo "[test] ROS_DOMAIN_ID=$ROS_DOMAIN_ID"
fi
# the slowest 20 tests and their times close every run (--durations=20)
"${PYTEST[@]}" "$@"
