"""
Perception without ROS: a simulated RGB-D camera's model and the point-cloud cluster filter.

- :mod:`.camera`: the camera's pose, intrinsics, depth noise and back-projection to a cloud;
- :mod:`.cloud_filter`: Interbotix's cluster pipeline (crop box, voxel grid, RANSAC plane,
  radius outlier removal, Euclidean clusters) on numpy arrays.

Frames: a camera's optical frame is REP-103's (z forward, x right, y down); poses are given in
the robot's base frame. Units: m, rad, s; colours 0..255.
"""
