"""px100_control.models."""
