"""``python -m visual_servoing``: the application framework's command (`application.cli`) for the
paper's experiment."""

import sys

from commandline import importing_command

with importing_command():
    from application.cli import main
    from visual_servoing.declaration import APPLICATION

sys.exit(main(APPLICATION))
