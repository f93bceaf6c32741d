"""
One line instead of a ModuleNotFoundError when a script runs outside the project's venv.

Stdlib only, so a script can call :func:`require` before importing numpy, matplotlib or rclpy.
"""
import importlib.util
import os
import sys

#: what a user runs to get the venv and the build, from the repository root
SETUP_HINT = 'run `bash scripts/setup.sh` then `source scripts/env.sh` first'


def missing_modules(*modules: str) -> list:
    """Return the top-level modules of ``modules`` that cannot be imported here."""
    return [m for m in modules if importlib.util.find_spec(m) is None]


def require(*modules: str) -> None:
    """Exit with one line (status 1) naming the missing modules and the set-up commands."""
    missing = missing_modules(*modules)
    if missing:
        sys.exit(f"{os.path.basename(sys.argv[0] or 'python')}: {', '.join(missing)} not "
                 f"found (the project's venv is not active): {SETUP_HINT}")
