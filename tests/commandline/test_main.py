"""`commandline.run` and `commandline.entry_point`: the exit codes, the error line, --debug, Ctrl-C
and a closed pipe."""

from __future__ import annotations

import contextlib
import importlib
import os
import subprocess
import sys
import textwrap
from pathlib import Path

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
    entry_point,
    run,
)

ROOT = Path(__file__).resolve().parents[2]


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


@contextlib.contextmanager
def interrupt_kept_in():
    """A Ctrl-C the code under test lets out fails the test that let it, not the whole run."""
    try:
        yield
    except KeyboardInterrupt:
        pytest.fail("the Ctrl-C escaped: a traceback, and the program dies of SIGINT")


def test_ctrl_c_while_the_arguments_are_parsed_is_interrupted_too(capsys):
    def pressed(_text: str) -> int:
        raise KeyboardInterrupt  # as a Ctrl-C lands in argparse on a loaded machine

    parser = command_parser("tool", "A tool.")
    parser.add_argument("--count", type=pressed)
    parser.set_defaults(func=lambda args: 0)
    with interrupt_kept_in():
        assert run(parser, PackageError, ["--count", "3"]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "interrupted\n"


ENTRY_POINTS = {
    "hexmigrate": "hexmigrate.cli",
    "firmware_sim": "firmware_sim.cli.command",
    "refresh": "refresh.cli",
    "morphing_crossbar": "morphing_crossbar.cli",
    "servo_emulators": "servo_emulators.cli",
    "patrol": "application.cli",
    "tank": "application.cli",
    "visual_servoing": "application.cli",
}


@pytest.mark.parametrize("package", sorted(ENTRY_POINTS))
def test_ctrl_c_anywhere_in_an_entry_point_is_interrupted_not_a_traceback(
    package, monkeypatch, capsys
):
    """Ctrl-C before `run` catches it (the command building its parser) says "interrupted"
    and exits 130, as in the command; `python -m` and the installed commands run this `main`."""

    def building(*_args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(importlib.import_module(ENTRY_POINTS[package]), "main", building)
    program = importlib.import_module(f"{package}.__main__")
    with interrupt_kept_in(), pytest.raises(SystemExit) as exited:
        program.main()
    assert exited.value.code == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "interrupted\n"


def test_ctrl_c_caught_in_a_dataclass_s_making_still_exits_130_under_python_m(tmp_path):
    """A Ctrl-C that lands where dataclasses and namedtuple make their methods (an ``exec`` of
    source text, which CPython marks) made ``python -m`` die of SIGINT (-2) after the program
    had said "interrupted" and chosen 130."""
    (tmp_path / "interrupted_program.py").write_text(
        textwrap.dedent(
            """
            import sys
            from commandline import entry_point

            def main():
                with entry_point():
                    exec("raise KeyboardInterrupt")  # as a Ctrl-C lands in a dataclass's making

            sys.exit(main())
            """
        )
    )
    done = subprocess.run(
        [sys.executable, "-m", "interrupted_program"],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert (done.returncode, done.stderr) == (EXIT_INTERRUPTED, "interrupted\n")


def test_entry_point_lets_the_exit_status_through():
    with pytest.raises(SystemExit) as exited, entry_point():
        raise SystemExit(EXIT_USAGE)
    assert exited.value.code == EXIT_USAGE


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


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize(
    "lines, argv",
    [
        (1, ["go"]),  # refused at the command's end
        (200000, ["go"]),  # midway
        (0, ["--help"]),  # argparse swallows the OSError of its help: the exit status was 0
        (0, ["go", "--help"]),
    ],
)
def test_output_the_disk_refuses_is_an_error_naming_standard_output(lines, argv):
    script = textwrap.dedent(
        f"""
        import sys
        from commandline import add_command, command_parser, run

        def say(args):
            for n in range({lines}):
                print(f"line {{n}}")

        parser = command_parser("say", "Says.")
        add_command(parser.add_subparsers(required=True), "go", say, "say")
        sys.exit(run(parser, Exception, {argv!r}))
        """
    )
    with open("/dev/full", "w") as full:  # every write: No space left on device
        done = subprocess.run(
            [sys.executable, "-c", script], stdout=full, stderr=subprocess.PIPE, text=True,
            timeout=60,
        )  # fmt: skip
    assert (done.returncode, done.stderr) == (
        EXIT_ERROR,
        "error: standard output: No space left on device\n",
    )


def test_a_command_imports_numpy_without_a_blas_thread_pool():
    """A pool of a thread per core, started at numpy's import, cost every process of the
    toolchain 60 to 130 ms of CPU; one the user asks for is kept."""
    script = textwrap.dedent(
        """
        import os
        from commandline import entry_point

        with entry_point():
            import numpy
        print(len(os.listdir("/proc/self/task")), os.environ.get("OPENBLAS_NUM_THREADS"))
        """
    )
    environment = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
        env=environment,
    )  # fmt: skip
    assert done.stdout.split() == ["1", "1"], done.stderr
    chosen = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
        env={**environment, "OPENBLAS_NUM_THREADS": "2"},
    )  # fmt: skip
    assert chosen.stdout.split() == ["2", "2"], chosen.stderr
