"""``python -m morphing_crossbar``: see `morphing_crossbar.cli`."""

import sys

from commandline import importing_command

with importing_command():
    from morphing_crossbar.cli import main

sys.exit(main())
