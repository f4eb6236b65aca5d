"""``python -m visual_servoing``: see `visual_servoing.experiment.cli`."""

import sys

from commandline import importing_command

with importing_command():
    from visual_servoing.experiment.cli import main

sys.exit(main())
