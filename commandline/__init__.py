"""The one command-line convention of the toolchain's entry points.

`hexmigrate`, `firmware-sim`, ``python -m refresh``, ``python -m visual_servoing``,
``python -m patrol``, ``python -m morphing_crossbar`` and ``python -m servo_emulators`` all
build their parser with `command_parser`, take numbers and files through the types in
`commandline.arguments`, show long jobs with `commandline.progress`, stop a job that writes as it
goes between two of its steps on Ctrl-C or SIGTERM with `commandline.interrupts`, and hand their
parser and their package's error root to `run`, which owns ``--debug``, the exit codes and the
``error: ...`` line. A file made in one piece (a module, an image, a key, a report, a figure) is
written whole or not at all with `commandline.output`, and a node's lines go out through its
`serving_output`.

This package sits below every other one: it imports none of the toolchain's packages.
"""

from commandline.main import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_PIPE_CLOSED,
    EXIT_USAGE,
    SHOWN,
    CommandLineError,
    UsageError,
    add_command,
    command_parser,
    entry_point,
    one_line,
    run,
)

__all__ = [
    "EXIT_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_PIPE_CLOSED",
    "EXIT_USAGE",
    "SHOWN",
    "CommandLineError",
    "UsageError",
    "add_command",
    "command_parser",
    "entry_point",
    "one_line",
    "run",
]
