"""
Locate the package's data files (urdf/, config/).

A source checkout uses its own folders; an installed package uses its ament share directory.
"""
import os

PACKAGE = 'px100_control'
_SOURCE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def share_dir() -> str:
    """
    Return the folder that holds urdf/ and config/.

    :return: the source checkout root when running from source, else the ament share dir.
    """
    if os.path.isfile(os.path.join(_SOURCE_ROOT, 'package.xml')):
        return _SOURCE_ROOT
    from ament_index_python.packages import get_package_share_directory  # optional: installs only
    return get_package_share_directory(PACKAGE)


def data_path(*parts: str) -> str:
    """Return the absolute path of a data file under share_dir() (e.g. urdf/px100.urdf)."""
    return os.path.join(share_dir(), *parts)
