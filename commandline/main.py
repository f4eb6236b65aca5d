"""`run`: parse, dispatch to the command, and turn what happened into an exit status.

Exit statuses (the same for every entry point):

    0    success
    1    an error the user can fix: one line ``error: ...`` on standard error
    2    a usage error: argparse's usage line and ``PROG: error: ...``
    130  interrupted (Ctrl-C): one line ``interrupted``
    141  standard output closed by its reader (``... | head -1``): nothing more is printed

``--debug`` (added by `command_parser`) prints the traceback before the ``error:`` line. A module
of an optional extra that is not installed is an error line that says what to install
(`commandline.extras`). Any other exception outside the package's error root and `OSError` is a
bug, not bad input: it is not caught, so its traceback shows where to look.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, NoReturn, TextIO

from commandline.extras import missing_extra
from commandline.output import STANDARD_OUTPUT, drop_standard_output, named

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_PIPE_CLOSED = 141  # 128 + SIGPIPE, what a shell reports for a C tool in the same place

Command = Callable[[argparse.Namespace], int | None]


class CommandLineError(Exception):
    """A failure the user can fix that no package's error tree names (arguments that only fail
    together, a file of the wrong kind): one ``error:`` line, exit status 1."""


class UsageError(CommandLineError):
    """Arguments that do not go together: reported as argparse reports its own, exit status 2."""


class CommandParser(argparse.ArgumentParser):
    """argparse's parser, but a usage error shows what is not printable in it escaped: the
    message quotes what the user gave (an unknown argument, a file name), which may hold an
    escape sequence, from a file name a shell glob found or a pasted line, that a terminal would
    act on. Its sub-commands' parsers are of this class too (argparse makes them of the type of
    the parser that adds them)."""

    def error(self, message: str) -> NoReturn:
        super().error(visible(message))


def command_parser(
    prog: str, description: str, epilog: str | None = None
) -> argparse.ArgumentParser:
    """A parser with ``--debug`` whose description and epilog keep their own line breaks, so
    that examples stay one per line."""
    parser = CommandParser(
        prog=prog,
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of an error, then the error"
    )
    return parser


def add_command(
    commands: argparse._SubParsersAction,
    name: str,
    func: Command,
    help: str,
    description: str | None = None,
) -> argparse.ArgumentParser:
    """A sub-command that runs `func(args)`; its ``--help`` starts with `description` (default:
    the one-line `help`), line breaks kept."""
    command = commands.add_parser(
        name,
        help=help,
        description=description or help,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    command.set_defaults(func=func)
    return command


def run(
    parser: argparse.ArgumentParser,
    errors: type[BaseException] | tuple[type[BaseException], ...],
    argv: Sequence[str] | None = None,
) -> int:
    """Parse `argv`, run the command the parser chose (its ``func`` default) and return the exit
    status. `errors` is the package's error root (or roots): those, `CommandLineError` and
    `OSError` become one ``error:`` line. Meanwhile standard output names itself in the errors
    of writes it refuses (`NamedOutput`)."""
    output = NamedOutput(sys.stdout)
    sys.stdout = output
    try:
        return _run(parser, errors, argv)
    except SystemExit:
        if output.refused is None:
            raise
        return _output_refused(output.refused)
    finally:
        if sys.stdout is output:  # a command may have put another in its place
            sys.stdout = output.stream


def _run(
    parser: argparse.ArgumentParser,
    errors: type[BaseException] | tuple[type[BaseException], ...],
    argv: Sequence[str] | None,
) -> int:
    caught = (errors if isinstance(errors, tuple) else (errors,)) + (CommandLineError, OSError)
    debug = False
    try:
        args = parser.parse_args(argv)  # Ctrl-C here too: on a loaded machine it takes a while
        debug = getattr(args, "debug", False)
        status = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
    except BrokenPipeError:
        return _pipe_closed()
    except UsageError as error:
        parser.error(str(error))
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except caught as error:
        if isinstance(error, OSError) and error.filename == STANDARD_OUTPUT:
            drop_standard_output()  # the interpreter's final flush would fail on them again
        return _error_line(describe(error), debug)
    except ModuleNotFoundError as error:
        problem = missing_extra(error)
        if problem is None:
            raise
        return _error_line(problem, debug)
    return EXIT_OK if status is None else status


def _output_refused(error: OSError) -> int:
    """The exit status of a parser's exit whose text standard output refused: argparse prints
    ``--help`` and swallows an OSError, so ``--help > /dev/full`` ended with status 0 and no
    word."""
    if isinstance(error, BrokenPipeError):
        return _pipe_closed()
    drop_standard_output()
    return _error_line(describe(error), debug=False)


class NamedOutput:
    """Standard output whose refused writes name it: output into a file on a full disk fails
    with an OSError that names no file, and ``error: [Errno 28] No space left on device`` would
    leave the user to guess which file. A closed pipe stays a BrokenPipeError (`_pipe_closed`);
    everything but writing is the stream's own. The last refusal is kept in `refused`, for
    `run` to report it when the writer swallowed it (argparse does)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.refused: OSError | None = None

    def write(self, text: str) -> int:
        with self._refusals():
            return self.stream.write(text)

    def flush(self) -> None:
        with self._refusals():
            self.stream.flush()

    @contextmanager
    def _refusals(self) -> Iterator[None]:
        """An OSError of the stream, named and kept in `refused`."""
        try:
            with named(STANDARD_OUTPUT):
                yield
        except OSError as error:
            self.refused = error
            raise

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


@contextmanager
def entry_point() -> Iterator[None]:
    """Around the whole of a command's entry point, its imports and its call of `run`: a module
    of a missing extra ends the program with one ``error:`` line and exit status 1 before any
    command runs, and Ctrl-C while the imports run or the parser is built (they take a while on
    a loaded machine) with ``interrupted`` and 130, as during the command; it printed a
    traceback and the program died of the signal. The exit status is the program's own
    (`_forget_caught_interrupts`). Numpy's BLAS runs on one thread (`one_blas_thread`)."""
    one_blas_thread()
    try:
        yield
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        raise SystemExit(EXIT_INTERRUPTED) from None
    except ModuleNotFoundError as error:
        problem = missing_extra(error)
        if problem is None:
            raise
        raise SystemExit(_error_line(problem, debug=False)) from None
    finally:
        _forget_caught_interrupts()


def one_blas_thread() -> None:
    """Numpy's BLAS (OpenBLAS, in numpy's wheels) on one thread in this process and the ones it
    starts, unless the user chose otherwise, when called before numpy is imported. Its pool of
    a thread per core, started at import, cost each process 60 to 130 ms of CPU (a node, a
    launcher's every process, the test suite's 900): the toolchain's matrices (the hexapod's
    6x6, the patrol's Kalman filter) are far too small for a pool to help."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _forget_caught_interrupts() -> None:
    """Let the program's exit status through. CPython marks a KeyboardInterrupt that leaves an
    ``exec`` or ``eval`` of source text as unhandled, even when the program catches it further
    up, and ``python -m`` then ends the program by SIGINT (status -2) instead of its own exit
    status: dataclasses and namedtuple make their methods so, at import, and a Ctrl-C in the
    first second of a command lands there often. The next such ``exec`` that ends normally
    clears the mark: one of nothing, as the program ends."""
    exec("")


def _error_line(text: str, debug: bool) -> int:
    """Print the error line (after the traceback of the error being handled, with --debug).
    What is not printable in it is shown escaped: a message may quote what a node, a child
    process or a file said, and a terminal must not take its escapes as commands."""
    if debug:
        traceback.print_exc()
    if len(text) > MAX_ERROR:
        text = f"{text[:MAX_ERROR]}... ({len(text) - MAX_ERROR} more characters)"
    print(f"error: {visible(text)}", file=sys.stderr)
    return EXIT_ERROR


SHOWN = 400
"""Characters of one text from a node or a module (a description, a name, an answer) a command
shows at most, escaped (`one_line`)."""
MAX_ERROR = 2000
"""Characters of an error a command prints at most: a message may quote what a hostile node
sent (one error line was 900 KB)."""


LAYOUT = "\n\t"
"""What an error may keep of its own layout: an error quoting a tool's last lines (a build's,
yosys's) is several lines, indented."""


def visible(text: str) -> str:
    """`text` with every character that is not printable, but line breaks and tabs, shown as
    Python escapes it (``\\x1b``, ``\\r``), the rest as it is: an escape sequence quoted from a
    child, a node or a file cannot act on the terminal."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c in LAYOUT else repr(c)[1:-1] for c in text)


def one_line(text: str, limit: int | None = None) -> str:
    """`text` as one line of data: every character that is not printable, line breaks and tabs
    included, shown as Python escapes it. What a module or a node wrote is shown so, never acted
    on by the terminal nor taken for lines of the program's own. With `limit`, at most that many
    characters of `text` are shown, and how many more there were is said."""
    if limit is not None and len(text) > limit:
        return f"{one_line(text[:limit])}... ({len(text) - limit} more characters)"
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def describe(error: BaseException) -> str:
    """An error as its one line: an `OSError` names the file and the system's reason."""
    if isinstance(error, OSError) and error.filename is not None and error.strerror:
        return f"{error.filename}: {error.strerror}"
    return str(error) or type(error).__name__


def _pipe_closed() -> int:
    """Standard output's reader went away: point it at /dev/null so that the interpreter's
    final flush does not print "Broken pipe", and stop."""
    drop_standard_output()
    return EXIT_PIPE_CLOSED
