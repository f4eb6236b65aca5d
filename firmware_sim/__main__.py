"""``python -m firmware_sim``: the ``firmware-sim`` command (see `firmware_sim.cli.command`)."""

import sys

from commandline import importing_command

with importing_command():
    from firmware_sim.cli.command import main

sys.exit(main())
