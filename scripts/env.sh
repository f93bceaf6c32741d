# Source me: activates the project venv and the colcon install (after scripts/setup.sh), and puts
# the package's executables on PATH.
_PX100_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_PX100_VENV=${PX100_VENV:-$_PX100_ROOT/.venv}
case $- in *u*) _PX100_NOUNSET=1; set +u ;; *) _PX100_NOUNSET= ;; esac  # setup.bash is not set -u safe
# shellcheck disable=SC1091
source "$_PX100_VENV/bin/activate"
export AMENT_PREFIX_PATH="$_PX100_VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# shellcheck disable=SC1091
source "$_PX100_ROOT/install/setup.bash"  # also ROS_DISTRO (colcon.pkg hook)
# The executables as commands (inspect, bringup, ...): the files `ros2 run px100_control <name>`
# resolves through the ament index (<prefix>/lib/px100_control/<name>).
_PX100_BIN="$_PX100_ROOT/install/px100_control/lib/px100_control"
case ":$PATH:" in *":$_PX100_BIN:"*) ;; *) export PATH="$_PX100_BIN:$PATH" ;; esac
unset _PX100_BIN
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
[ -n "$_PX100_NOUNSET" ] && set -u
unset _PX100_NOUNSET
