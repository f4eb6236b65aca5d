"""`commandline.run`: the exit codes, the error line, --debug and a closed pipe."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from commandline import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_PIPE_CLOSED,
    EXIT_USAGE,
    CommandLineError,
    UsageError,
    add_command,
    command_parser,
    run,
)


class PackageError(Exception):
    """Stands for a package's error root."""


def parser_raising(error: BaseException | None):
    parser = command_parser("tool", "A tool.\n\n    tool go\n    tool go --fast")
    commands = parser.add_subparsers(required=True, metavar="COMMAND")

    def go(args) -> int:
        if error is not None:
            raise error
        print("went")
        return 0

    add_command(commands, "go", go, "go somewhere")
    return parser


def test_success_returns_zero(capsys):
    assert run(parser_raising(None), PackageError, ["go"]) == 0
    assert capsys.readouterr().out == "went\n"


@pytest.mark.parametrize(
    "error",
    [PackageError("the node said no"), CommandLineError("the node said no")],
)
def test_an_error_of_the_root_is_one_line_and_exit_1(capsys, error):
    assert run(parser_raising(error), PackageError, ["go"]) == EXIT_ERROR
    err = capsys.readouterr().err
    assert err == "error: the node said no\n"


def test_an_error_keeps_its_lines_and_shows_every_other_control_character_escaped(capsys):
    said = PackageError("the build failed:\n\tline 1\r\x1b[2J\n\tline 2")
    assert run(parser_raising(said), PackageError, ["go"]) == EXIT_ERROR
    err = capsys.readouterr().err
    assert err == "error: the build failed:\n\tline 1\\r\\x1b[2J\n\tline 2\n"


def test_an_os_error_names_the_file(capsys):
    error = FileNotFoundError(2, "No such file or directory", "gain.hex")
    assert run(parser_raising(error), PackageError, ["go"]) == EXIT_ERROR
    assert capsys.readouterr().err == "error: gain.hex: No such file or directory\n"


def test_debug_shows_the_traceback_then_the_line(capsys):
    assert run(parser_raising(PackageError("bad")), PackageError, ["--debug", "go"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("Traceback") and err.endswith("error: bad\n")


def test_an_error_outside_the_root_is_a_bug_and_not_hidden():
    with pytest.raises(ZeroDivisionError):
        run(parser_raising(ZeroDivisionError("oops")), PackageError, ["go"])


def test_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as exited:
        run(parser_raising(UsageError("--a and --b go together")), PackageError, ["go"])
    assert exited.value.code == EXIT_USAGE
    assert "tool: error: --a and --b go together" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exited:
        run(parser_raising(None), PackageError, ["fly"])
    assert exited.value.code == EXIT_USAGE


def test_a_usage_error_shows_the_escapes_it_quotes_escaped(capsys):
    with pytest.raises(SystemExit) as exited:
        run(parser_raising(None), PackageError, ["go", "\x1b[2J\x1b]0;title\x07"])
    assert exited.value.code == EXIT_USAGE
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\x07" not in err
    assert err.endswith("tool: error: unrecognized arguments: \\x1b[2J\\x1b]0;title\\x07\n")


def test_interrupted_exits_130(capsys):
    assert run(parser_raising(KeyboardInterrupt()), PackageError, ["go"]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "interrupted\n"


def test_help_keeps_the_examples_on_their_own_lines(capsys):
    with pytest.raises(SystemExit):
        run(parser_raising(None), PackageError, ["--help"])
    out = capsys.readouterr().out
    assert "\n    tool go\n    tool go --fast\n" in out


def test_a_closed_pipe_ends_quietly():
    script = textwrap.dedent(
        """
        import sys
        from commandline import add_command, command_parser, run

        def flood(args):
            for n in range(200000):
                print(f"line {n}")

        parser = command_parser("flood", "Floods.")
        add_command(parser.add_subparsers(required=True), "go", flood, "flood")
        sys.exit(run(parser, Exception, ["go"]))
        """
    )
    pipeline = f"{sys.executable} -c '{script}' | head -1; echo status ${{PIPESTATUS[0]}}"
    done = subprocess.run(
        ["bash", "-c", pipeline], capture_output=True, text=True, timeout=60, check=True
    )
    assert done.stdout == f"line 0\nstatus {EXIT_PIPE_CLOSED}\n"
    assert done.stderr == ""
