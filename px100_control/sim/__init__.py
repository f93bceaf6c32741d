"""MuJoCo world of the simulated arm: scenes as files and the MuJoCo model built from the URDF."""
