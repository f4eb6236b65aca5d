"""``python -m refresh``: see `refresh.cli`."""

import sys

from commandline import importing_command

with importing_command():
    from refresh.cli import main

sys.exit(main())
