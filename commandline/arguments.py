"""Argument types shared by every command, so that one kind of value is checked one way.

Each is an argparse ``type=``: it returns the value or raises `argparse.ArgumentTypeError` with
what was expected and what came, which argparse turns into a usage error (exit status 2). Numbers
refuse NaN, infinities and values outside their range; files refuse directories, devices, pipes
and files larger than the command can sensibly read, so that no option leads to a hang or an
unbounded read.
"""

from __future__ import annotations

import argparse
import math
import stat
from collections.abc import Callable
from pathlib import Path

from commandline.main import UsageError

ADDRESS_LIMIT = 1 << 32
DEFAULT_MAX_FILE_BYTES = 64 << 20  # far above any module, database or ELF this toolchain reads


def real(
    minimum: float | None = None,
    maximum: float | None = None,
    *,
    above: float | None = None,
    unit: str = "",
) -> Callable[[str], float]:
    """A finite number within ``[minimum, maximum]`` (and greater than `above`, if given)."""
    wanted = _range_text("a number", minimum, maximum, above, unit)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise _expected(wanted, text) from None
        if not math.isfinite(value) or not _within(value, minimum, maximum, above):
            raise _expected(wanted, text)
        return value

    parse.__name__ = "number"  # argparse names the type in its messages
    return parse


def integer(
    minimum: int | None = None, maximum: int | None = None, *, unit: str = ""
) -> Callable[[str], int]:
    """A whole number (decimal or 0x...) within ``[minimum, maximum]``."""
    wanted = _range_text("a whole number", minimum, maximum, None, unit)

    def parse(text: str) -> int:
        try:
            value = int(text, 0)
        except ValueError:
            raise _expected(wanted, text) from None
        if not _within(value, minimum, maximum, None):
            raise _expected(wanted, text)
        return value

    parse.__name__ = "integer"
    return parse


def address(text: str) -> int:
    """A 32-bit address, decimal or 0x-prefixed hexadecimal."""
    try:
        value = int(text, 0)
    except ValueError:
        raise _expected("an address like 0x20000", text) from None
    if not 0 <= value < ADDRESS_LIMIT:
        raise _expected("an address from 0 to 0xFFFFFFFF", text)
    return value


def host_port(example: int) -> Callable[[str], tuple[str, int]]:
    """``HOST:PORT`` a server listens on (``[::1]:PORT`` for IPv6; port 0: any free one); a
    refusal shows ``127.0.0.1:EXAMPLE``."""

    def parse(text: str) -> tuple[str, int]:
        host, colon, port = text.rpartition(":")
        host = host.removeprefix("[").removesuffix("]")
        if not colon or not host or not port.isdigit() or int(port) > 65535:
            raise _expected(
                f"HOST:PORT with a port from 0 to 65535, like 127.0.0.1:{example}", text
            ) from None
        return host, int(port)

    return parse


def named_url(name: str) -> Callable[[str], tuple[str, str]]:
    """``NAME=URL`` (`name` says what names it: ROBOT, NAME): the name and the URL, neither
    empty."""

    def parse(text: str) -> tuple[str, str]:
        named, equals, url = text.partition("=")
        if not equals or not named or not url:
            raise argparse.ArgumentTypeError(f"expected {name}=URL, got {text!r}")
        return named, url

    parse.__name__ = f"{name}=URL"
    return parse


def path_name(text: str) -> Path:
    """A file's or folder's name, `text` as a path, for a command that checks the rest itself
    (a folder it makes): the system takes no NUL byte in one (making it would fail with a
    ValueError, not an OSError); nor is an empty name one (Path would take it for the current
    folder)."""
    if "\0" in text:
        raise _expected("a path", f"{text!r} (a NUL byte)", quote=False)
    if not text:
        raise _expected("a path", text)
    return Path(text)


def output_folder(text: str) -> Path:
    """A folder to write files in: one that exists, or a new one the command makes. A file, a
    device or a pipe of that name is refused here, where the option can be named, rather than
    when the command fails to make the folder."""
    path = path_name(text)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return path
    except OSError as error:  # a name too long, a loop of links, a folder that is a file
        raise argparse.ArgumentTypeError(f"{text}: {error.strerror}") from None
    if not stat.S_ISDIR(mode):
        kind = "a file" if stat.S_ISREG(mode) else _kind(mode)
        raise _expected("a folder to write in", f"{text} ({kind})", quote=False)
    return path


def input_file(max_bytes: int = DEFAULT_MAX_FILE_BYTES) -> Callable[[str], Path]:
    """An existing regular file of at most `max_bytes`."""

    def parse(text: str) -> Path:
        path = path_name(text)
        try:
            info = path.stat()
        except OSError as error:
            raise argparse.ArgumentTypeError(f"{text}: {error.strerror}") from None
        if not stat.S_ISREG(info.st_mode):
            raise _expected("a regular file", f"{text} ({_kind(info.st_mode)})", quote=False)
        if info.st_size > max_bytes:
            raise _expected(
                f"a file of at most {max_bytes:,} bytes",
                f"{text} ({info.st_size:,} bytes)",
                quote=False,
            )
        return path

    parse.__name__ = "file"
    return parse


def output_file(text: str) -> Path:
    """A file to write, in a folder that exists: a new file or a regular one to replace (a
    command writes beside it and renames, which would replace a device or a pipe)."""
    path = path_name(text)
    try:
        info = path.stat()
    except FileNotFoundError:
        info = None
    except OSError as error:  # a name too long, a loop of links, a folder that is a file
        raise argparse.ArgumentTypeError(f"{text}: {error.strerror}") from None
    if info is not None and not stat.S_ISREG(info.st_mode):
        wanted = "a file to write" if stat.S_ISDIR(info.st_mode) else "a regular file to write"
        raise _expected(wanted, f"{text} ({_kind(info.st_mode)})", quote=False)
    if not path.parent.is_dir():
        raise _expected("a file in an existing folder", text)
    return path


def apart(written: tuple[str, Path], *others: tuple[str, Path | None]) -> None:
    """Refuse an output file that is also another file of the command (`others`: each an
    option's name and its file, None when not given), as UsageError naming both options: the
    command would replace the input it reads, or one output with another (a private key with
    its public half), and what was there is lost."""
    option, path = written
    for other, given in others:
        if given is not None and _same_file(path, given):
            raise UsageError(
                f"{option} {path}: expected a file apart from {other}'s, got the same file"
            )


def _same_file(one: Path, other: Path) -> bool:
    """Whether two names are one file: the same inode when both exist, else the same path."""
    try:
        return one.samefile(other)
    except OSError:
        return one.resolve() == other.resolve()


def output_file_ending(suffix: str) -> Callable[[str], Path]:
    """A file to write whose name ends in `suffix`, for writers that pick the format by it
    (matplotlib and ``.png``)."""

    def parse(text: str) -> Path:
        path = output_file(text)
        if path.suffix.lower() != suffix:
            raise _expected(f"a file name ending in {suffix}", text)
        return path

    parse.__name__ = "file"
    return parse


def _within(
    value: float, minimum: float | None, maximum: float | None, above: float | None
) -> bool:
    return (
        (minimum is None or value >= minimum)
        and (maximum is None or value <= maximum)
        and (above is None or value > above)
    )


def _range_text(
    kind: str, minimum: float | None, maximum: float | None, above: float | None, unit: str
) -> str:
    suffix = f" {unit}" if unit else ""
    low = f"above {_shown(above)}" if above is not None else None
    if minimum is not None:
        low = f"from {_shown(minimum)}"
    if low and maximum is not None:
        return f"{kind} {low} to {_shown(maximum)}{suffix}"
    if low:
        return f"{kind} {low}{suffix}"
    if maximum is not None:
        return f"{kind} up to {_shown(maximum)}{suffix}"
    return f"a finite {kind.removeprefix('a ')}{suffix}"


def _shown(bound: float) -> str:
    """A bound as a user would type it: whole numbers in full (1000000, not 1e+06)."""
    return str(bound) if isinstance(bound, int) else f"{bound:g}"


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _expected(wanted: str, got: str, quote: bool = True) -> argparse.ArgumentTypeError:
    return argparse.ArgumentTypeError(
        f"expected {wanted}, got {got!r}" if quote else f"expected {wanted}, got {got}"
    )
