"""`python -m hexmigrate`: the same as the `hexmigrate` command."""

import sys

from hexmigrate.cli import main

sys.exit(main())
