"""``python -m firmware_sim.servos``: see firmware_sim.servos.cli."""

import sys

from commandline import importing_command

with importing_command():
    from firmware_sim.servos.cli import main

sys.exit(main())
