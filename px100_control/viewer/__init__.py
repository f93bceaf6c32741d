"""
The browser viewer's engine: what the page shows and how it is drawn with viser (no rclpy).

:mod:`.state` holds the viewed state (joints, world bodies, trail, trajectory, statuses) as
plain data and takes time as an argument; :mod:`.scene` draws it with viser and reports the
user's actions through callbacks; :mod:`.controls` checks the settings and turns a control
into a goal; :mod:`.bag_view` plays a recorded bag in the same page. The ROS adapter is
:mod:`px100_control.ros.viewer_node`. Frames: the scene root is the robot's base frame
(``<robot_name>/base_link``); units m, rad, s.
"""
