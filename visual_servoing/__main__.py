"""``python -m visual_servoing``: see `visual_servoing.experiment.cli`."""

import sys

from visual_servoing.experiment.cli import main

sys.exit(main())
