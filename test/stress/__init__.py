"""Fuzz, fault and load tests of the px100 nodes (``pytest -m stress``)."""
