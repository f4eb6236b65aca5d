"""``python -m servo_emulators``: see servo_emulators.cli."""

import sys

from commandline import importing_command

with importing_command():
    from servo_emulators.cli import main

sys.exit(main())
