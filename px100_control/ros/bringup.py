"""Placeholder entry point: replaced when its node is built (see the issue tracker)."""
import sys


def main(args=None):
    """Say that this executable is not built yet and exit non-zero."""
    print('px100_control: bringup is not built yet', file=sys.stderr)
    return 1


if __name__ == '__main__':
    sys.exit(main())
