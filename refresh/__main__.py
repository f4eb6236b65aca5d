"""``python -m refresh``: see `refresh.cli`."""

import sys

from refresh.cli import main

sys.exit(main())
