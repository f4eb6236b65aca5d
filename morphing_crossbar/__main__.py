"""``python -m morphing_crossbar``: see `morphing_crossbar.cli`."""

import sys

from morphing_crossbar.cli import main

sys.exit(main())
