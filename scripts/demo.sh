#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the main job: the pick-and-place demo through the
# Interbotix-compatible client (scripts/pick_and_place_demo.py). The simulated arm's nodes run
# inside the demo process; the run is recorded to an MCAP bag and plotted under out/ (the paths
# are printed at the end). Extra arguments go to the demo, e.g. `bash scripts/demo.sh --help`.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/scripts/setup.sh"
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
export MPLBACKEND=Agg
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
cd "$ROOT"
python scripts/pick_and_place_demo.py --out "$ROOT/out" "$@"
