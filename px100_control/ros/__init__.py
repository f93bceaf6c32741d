"""px100_control.ros."""
