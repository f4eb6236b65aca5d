"""``python -m patrol``: see `patrol.cli`."""

import sys

from commandline import importing_command

with importing_command():
    from patrol.cli import main

sys.exit(main())
