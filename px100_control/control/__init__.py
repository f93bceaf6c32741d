"""px100_control.control."""
