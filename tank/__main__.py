"""``python -m tank``: the application framework's command (`application.cli`) for the tank."""

import sys

from commandline import importing_command

with importing_command():
    from application.cli import main
    from tank.declaration import APPLICATION

sys.exit(main(APPLICATION))
