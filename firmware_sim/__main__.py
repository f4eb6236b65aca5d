"""``python -m firmware_sim`` and the ``firmware-sim`` command (see `firmware_sim.cli.command`)."""

import sys

from commandline import entry_point


def main() -> int:
    """The command, under `entry_point` from its first import to its exit status."""
    with entry_point():
        from firmware_sim.cli.command import main as command

        return command()


if __name__ == "__main__":
    sys.exit(main())
