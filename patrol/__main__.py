"""``python -m patrol``: the application framework's command (`application.cli`) for the patrol."""

import sys

from commandline import entry_point


def main() -> int:
    """The command, under `entry_point` from its first import to its exit status."""
    with entry_point():
        from application.cli import main as command
        from patrol.declaration import APPLICATION

        return command(APPLICATION)


if __name__ == "__main__":
    sys.exit(main())
