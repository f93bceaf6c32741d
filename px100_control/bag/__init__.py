"""
Rosbag2-compatible MCAP bags without ROS: write, read, recover, replay schedules, plots.

Pure Python (no rclpy, no ``*_msgs``): :mod:`~px100_control.bag.writer` (BagWriter),
:mod:`~px100_control.bag.reader` (BagReader, read_messages), :mod:`~px100_control.bag.reindex`
(recovery), :mod:`~px100_control.bag.replay` (ReplaySchedule), :mod:`~px100_control.bag.tf`
(/tf from joint states), :mod:`~px100_control.bag.plots` and the ``inspect`` command.
"""
