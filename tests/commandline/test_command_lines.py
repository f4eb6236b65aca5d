"""The one command-line convention, checked across every entry point at once: each has --debug,
its help shows no reST markup, each option name means one thing everywhere, and docs/cli.md
names every sub-command and option."""

from __future__ import annotations

import argparse
from collections import defaultdict
from collections.abc import Callable, Iterator

import pytest

from application.cli import build_parser as application_parser
from firmware_sim.cli.command import build_parser as firmware_sim_parser
from hexmanipulator.plot_sweep import build_parser as plot_sweep_parser
from hexmigrate.cli import build_parser as hexmigrate_parser
from morphing_crossbar.cli import build_parser as crossbar_parser
from patrol.declaration import APPLICATION as PATROL
from refresh.cli import build_parser as refresh_parser
from servo_emulators.cli import build_parser as servos_parser
from tank.declaration import APPLICATION as TANK
from tests.commandline.documented import undocumented
from visual_servoing.declaration import APPLICATION as SERVOING
from visual_servoing.figure import build_parser as figure_parser

APPLICATIONS = (
    "## The applications: `python -m visual_servoing`, `python -m patrol`, `python -m tank`"
)

ENTRY_POINTS: dict[str, tuple[Callable[[], argparse.ArgumentParser], str]] = {
    "hexmigrate": (hexmigrate_parser, "## `hexmigrate`"),
    "firmware-sim": (firmware_sim_parser, "## `firmware-sim`"),
    "refresh": (refresh_parser, "## `python -m refresh`"),
    **{
        application.name: (
            lambda application=application: application_parser(application),
            APPLICATIONS,
        )
        for application in (SERVOING, PATROL, TANK)
    },
    "morphing_crossbar": (crossbar_parser, "## `python -m morphing_crossbar`"),
    "servo_emulators": (servos_parser, "## `python -m servo_emulators`"),
    "hexmanipulator.plot_sweep": (plot_sweep_parser, "## The figure commands"),
    "visual_servoing.figure": (figure_parser, "## The figure commands"),
}
FILE_OPTIONS = {"--output"}
"""Options whose metavar names the kind of file (OUT.hex, OUT.bin, FILE.png): one meaning, the
file written, several spellings on purpose."""


def parsers(parser: argparse.ArgumentParser) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """`parser` and each of its sub-commands' parsers, with their prog names."""
    yield parser.prog, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from parsers(sub)


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_every_command_has_debug_and_help_without_rest_markup(name):
    build, _ = ENTRY_POINTS[name]
    top = build()
    assert "--debug" in top._option_string_actions
    for prog, parser in parsers(top):
        text = parser.format_help()
        assert "``" not in text, f"{prog} --help shows reST markup"


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_docs_cli_names_every_sub_command_and_option(name):
    build, heading = ENTRY_POINTS[name]
    assert undocumented(build(), heading) == []


def test_one_option_name_means_one_thing_in_every_command():
    spellings: dict[str, set[str]] = defaultdict(set)
    for build, _ in ENTRY_POINTS.values():
        for prog, parser in parsers(build()):
            for action in parser._actions:
                for option in action.option_strings:
                    if option.startswith("--") and option not in FILE_OPTIONS | {"--help"}:
                        spellings[option].add(f"{action.metavar or '(flag)'} in {prog}")
    differing = {
        option: sorted(uses)
        for option, uses in spellings.items()
        if len({use.split(" in ")[0] for use in uses}) > 1
    }
    assert differing == {}
