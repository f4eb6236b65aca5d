"""`python -m hexmigrate`: the same as the `hexmigrate` command."""

import sys

from commandline import importing_command

with importing_command():
    from hexmigrate.cli import main

sys.exit(main())
