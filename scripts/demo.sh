#!/usr/bin/env bash
# Set up (scripts/setup.sh) and run the main job.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$ROOT/scripts/setup.sh"
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
export MPLBACKEND=Agg
cd "$ROOT"
python -c "
from px100_control.models.registry import load_robot
import numpy as np
m = load_robot('px100')
np.set_printoptions(precision=4, suppress=True)
print('px100 end-effector pose at the sleep pose', m.sleep, ':'); print(m.fk(m.sleep))
"
