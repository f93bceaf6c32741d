"""Offscreen rendering on a machine without a display or GPU: MuJoCo's EGL backend."""
import os

os.environ.setdefault('MUJOCO_GL', 'egl')
