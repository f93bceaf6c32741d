"""Pure-numpy kinematics: SE(3) algebra, forward kinematics, Jacobians, IK. No rclpy here."""
