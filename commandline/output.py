"""Writing a command's output file whole or not at all, and a node's standard output.

A command that writes a file (a module, a relocated image, a key, a report, a figure, a
campaign's manifest) must never leave a cut one behind: a full disk, a file size limit or a kill
midway would leave a file that looks like an output and is not (a cut manifest would even hold
its campaign's folder against both a new start and ``--resume``). The bytes go to
``NAME.partial`` beside it, moved over NAME once whole. A node's standard output, on the other
hand, is a log, not a result: one the disk refuses costs the node (or the manager) its output,
never its life.
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

STANDARD_OUTPUT = "standard output"
"""The name `named` gives standard output in an error: ``error: standard output: ...``."""


class Figure(Protocol):
    """What `save_figure` needs of a figure (matplotlib's; this layer does not import it)."""

    def savefig(self, fname: Any, **options: Any) -> None: ...


@contextmanager
def named(name: str) -> Iterator[None]:
    """An OSError raised inside names `name`: a write's own names no file, and `commandline.run`
    words the error with the file it names (``error: NAME: No space left on device``). A closed
    pipe stays a BrokenPipeError, which `commandline.run` ends quietly."""
    try:
        yield
    except BrokenPipeError:
        raise
    except OSError as error:
        raise OSError(error.errno, error.strerror, name) from None


def write_whole(path: Path, data: bytes, mode: int = 0o666) -> None:
    """`data` into `path` (created with `mode`, less the umask): the old file or the new one
    afterwards, never a cut one. An OSError names `path` and leaves no ``.partial``."""
    partial = path.with_name(path.name + ".partial")
    with named(str(path)):
        try:
            # A new file each time: one left by a killed run (or a symlink put there) would keep
            # its mode, a private key's too, or lead the bytes into another file.
            partial.unlink(missing_ok=True)
            descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode)
            with os.fdopen(descriptor, "wb") as file:
                file.write(data)
            partial.replace(path)
        except OSError:
            partial.unlink(missing_ok=True)
            raise


def save_figure(figure: Figure, path: Path, **options: Any) -> None:
    """`figure` drawn into `path` in the format its suffix names (``savefig``'s `options`),
    whole or not at all: drawn in memory first, then written by `write_whole` (``savefig`` to a
    path writes as it draws, and leaves a cut image behind when the disk refuses the rest)."""
    drawn = io.BytesIO()
    figure.savefig(drawn, format=path.suffix.lstrip(".") or None, **options)
    write_whole(path, drawn.getvalue())


def serving_output(program: str, who: str = "the node") -> Callable[[str], None]:
    """What a program others depend on while it runs (`who`: a node, the manager of robots)
    says, each line out at once (a user, a launcher or a gdb user waits for it). Standard
    output on a disk that refuses it (full, a file size limit: a launcher keeps it in a log
    file) loses the program its output, not its life: `program` says so once on standard error
    and runs on; a closed pipe still ends the command (``commandline.run``: 141)."""

    def say(line: str) -> None:
        try:
            print(line, flush=True)
        except BrokenPipeError:
            raise
        except OSError as error:
            drop_standard_output()
            print(
                f"{program}: cannot write standard output: {error.strerror}; {who} runs on "
                "without it",
                file=sys.stderr,
                flush=True,
            )

    return say


def drop_standard_output() -> None:
    """Point standard output at /dev/null: what it still holds, and all it is given from now on,
    goes nowhere without error (a reader gone, a disk that refuses it)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
