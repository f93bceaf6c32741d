# px100_control environment hook: the ROS 2 distribution this package is built for
# (ros2 doctor and rosdep read ROS_DISTRO; an apt install sets it in /opt/ros/jazzy).
if [ -z "${ROS_DISTRO:-}" ]; then
  export ROS_DISTRO=jazzy
fi
