# Source me: activates the project venv and the colcon install (after scripts/setup.sh).
_PX100_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_PX100_VENV=${PX100_VENV:-$_PX100_ROOT/.venv}
case $- in *u*) _PX100_NOUNSET=1; set +u ;; *) _PX100_NOUNSET= ;; esac  # setup.bash is not set -u safe
# shellcheck disable=SC1091
source "$_PX100_VENV/bin/activate"
export AMENT_PREFIX_PATH="$_PX100_VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# shellcheck disable=SC1091
source "$_PX100_ROOT/install/setup.bash"
# the package's environment hook (ROS_DISTRO=jazzy): colcon sources it from install/setup.bash
# where colcon.pkg hooks are honoured (colcon-common-extensions); this minimal colcon does not
# shellcheck disable=SC1091
_PX100_HOOK=$_PX100_ROOT/install/px100_control/share/px100_control/environment/ros_distro.sh
[ -f "$_PX100_HOOK" ] && source "$_PX100_HOOK"
unset _PX100_HOOK
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
[ -n "$_PX100_NOUNSET" ] && set -u
unset _PX100_NOUNSET
