"""px100_control.bag."""
