"""px100_control.client."""
