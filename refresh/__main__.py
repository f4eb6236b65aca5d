"""``python -m refresh``: see `refresh.cli`."""

import sys

from commandline import entry_point


def main() -> int:
    """The command, under `entry_point` from its first import to its exit status."""
    with entry_point():
        from refresh.cli import main as command

        return command()


if __name__ == "__main__":
    sys.exit(main())
