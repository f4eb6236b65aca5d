"""``python -m patrol``: the application framework's command (`application.cli`) for the patrol."""

import sys

from commandline import importing_command

with importing_command():
    from application.cli import main
    from patrol.declaration import APPLICATION

sys.exit(main(APPLICATION))
