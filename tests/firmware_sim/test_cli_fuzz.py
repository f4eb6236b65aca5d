"""Hostile input: `firmware-sim` given random option values, in process.

Whatever the values, the command ends (no hang: every run is kept tiny by its --seconds or
--cycles, every node listens on a URL that fails fast or for a few milliseconds), its exit status
is 0, 1 or 2, and standard error holds no traceback: bad input is an ``error:`` line or a usage
error, never a crash.
"""

from __future__ import annotations

import contextlib
import io
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.cli.command import main
from hexmigrate.elf import image_from_elf

EXAMPLES = 40
HANG_SECONDS = 20
"""A command that has not ended after this long hangs: the test fails."""
HOSTILE = [
    "", " ", "-", "--", "=", ".", "..", "@", "nan", "-nan", "NaN", "inf", "-inf", "1e309",
    "-1e309", "1e-320", "-1", "0", "0x", "0x-1", "-0", "0.5", "1_000", "99999999999999999999",
    "\x00", "\n", "é", "a.b", "a.b=c", "a=b", "a.b=", "=a.b", "signal", "signal.y",
    "signal.y=gain.x", "signal.amplitude=0.5", "signal.shape=7", "gain.k=0x20000",
    "gain.x=signal.y", "signal=5", "signal=0", "gain=1e9",
]  # fmt: skip
"""Values that broke, or could break, a parser somewhere."""
TINY_SECONDS = ["0.01", "0.02", "1e-9"]
"""--seconds values that run: short, so that no example runs long."""
REFUSED_SECONDS = ["0", "-1", "nan", "inf", "1e309", "abc", "", "2e6"]
"""--seconds values that are refused before anything runs."""
FAST_URLS = [
    "nowhere://x", "/nonexistent/tty0", "can://nosuch/x", "faulty+nowhere://x", "loop://",
    "pty", "tcp-listen://127.0.0.1:0", "tcp-listen://256.1.1.1:0", "socket://", "can://virtual/",
    "faulty+loop://#drop=2", "faulty+loop://#seed=x",
]  # fmt: skip
"""Listen URLs that fail at once or serve for the tiny --seconds given."""

values = st.one_of(
    st.sampled_from(HOSTILE),
    st.text(max_size=12),
    st.integers().map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


def option(name: str, value: st.SearchStrategy[str] = values) -> st.SearchStrategy[list[str]]:
    return value.map(lambda text: [name, text])


def options(*choices: st.SearchStrategy[list[str]]) -> st.SearchStrategy[list[str]]:
    """Up to five of `choices`, flattened."""
    return st.lists(st.one_of(*choices), max_size=5).map(
        lambda parts: [word for part in parts for word in part]
    )


def length() -> st.SearchStrategy[list[str]]:
    """How long a run lasts: short, a few cycles, or a refused value."""
    return st.one_of(
        option("--seconds", st.sampled_from(TINY_SECONDS + REFUSED_SECONDS)),
        option("--cycles", st.sampled_from(["1", "3", "0", "-1", "1.5", "x", "1e3"])),
    )


def pbo_options() -> list[st.SearchStrategy[list[str]]]:
    """The options of run and listen that start and wire PBOs."""
    return [
        option("--native", st.one_of(st.just("signal"), values)),
        option("--wire"),
        option("--set"),
        option("--rate"),
        option("--default-rate"),
    ]


@pytest.fixture(scope="module")
def files(example_builds, tmp_path_factory) -> dict[str, str]:
    folder = tmp_path_factory.mktemp("fuzz")
    gain = folder / "gain.hex"
    image_from_elf(example_builds["gain"].elf).write(gain)
    corrupt = folder / "corrupt.hex"
    corrupt.write_text(gain.read_text().replace(":", ";", 3))
    return {
        "gain": str(gain),
        "corrupt": str(corrupt),
        "missing": str(folder / "missing.hex"),
        "folder": str(folder),
        "flash": str(folder / "flash.bin"),
    }


def module_files(files: dict[str, str]) -> st.SearchStrategy[str]:
    """A module argument: a real, corrupt, missing or odd file, maybe @ an address."""
    path = st.sampled_from([*files.values(), "/dev/zero", "/", ""])
    where = st.one_of(st.just(""), values.map(lambda text: "@" + text))
    return st.tuples(path, where).map("".join)


class Hang(BaseException):
    """A command ran longer than HANG_SECONDS (a BaseException: no command may catch it)."""


@contextlib.contextmanager
def bounded(argv: list[str]) -> Iterator[None]:
    """Raise Hang in the main thread if `argv` runs longer than HANG_SECONDS."""

    def expire(signum: int, frame: object) -> None:
        raise Hang(f"firmware-sim {argv} still runs after {HANG_SECONDS} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, HANG_SECONDS)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def call(argv: list[str]) -> tuple[int, str]:
    """`main(argv)`'s exit status (argparse's too) and what it wrote to standard error."""
    err = io.StringIO()
    with (
        bounded(argv),
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(io.StringIO()),
    ):
        try:
            status = main(argv)
        except SystemExit as exit_:
            status = exit_.code if isinstance(exit_.code, int) else 1
    return status, err.getvalue()


def check(argv: list[str]) -> None:
    status, err = call(argv)
    assert status in (0, 1, 2), (argv, status, err)
    assert "Traceback" not in err, (argv, err)


FUZZ = settings(
    max_examples=EXAMPLES,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(data=st.data())
def test_run_with_hostile_values(files, data):
    modules = options(module_files(files).map(lambda text: ["--module", text]))
    argv = ["run", *data.draw(modules), *data.draw(options(*pbo_options(), option("--json")))]
    check([*argv, *data.draw(length())])


@FUZZ
@given(data=st.data())
def test_listen_with_hostile_values(files, data):
    url = st.one_of(st.sampled_from(FAST_URLS), st.text(max_size=12))
    chosen = options(
        *pbo_options(),
        option("--show"),
        option("--name"),
        option("--fpga", st.one_of(st.integers(-2, 20).map(str), values)),
        option(
            "--flash",
            st.sampled_from([files["flash"], files["folder"], "/dev/null", "/dev/zero", ""]),
        ),
    )
    seconds = st.sampled_from(TINY_SECONDS + REFUSED_SECONDS)
    argv = ["listen", "--listen", data.draw(url), *data.draw(chosen)]
    check([*argv, "--seconds", data.draw(seconds)])


@FUZZ
@given(data=st.data())
def test_transfer_with_hostile_values(files, data):
    path = st.sampled_from([*files.values(), "/dev/zero", "/"])
    chosen = options(
        option("--medium", st.one_of(st.sampled_from(["serial", "can", "CAN"]), values)),
        option("--bit-rate"),
        option("--mode", st.one_of(st.sampled_from(["binary", "hex"]), values)),
        option("--window", st.one_of(st.integers(-1, 300).map(str), values)),
        option("--json"),
    )
    check(["transfer", data.draw(path), *data.draw(chosen)])


@FUZZ
@given(extra=st.lists(values, max_size=3))
def test_info_and_stray_words(extra):
    check(["info", *extra])
    check(extra)


def test_a_tiny_run_and_a_tiny_listen_succeed(files):
    """The fuzzed commands can succeed: these two do, so a fuzz that only ever sees errors would
    not pass for a fuzz of the working paths."""
    assert call(["run", "--module", files["gain"], "--set", "gain.k=1", "--cycles", "3"])[0] == 0
    assert call(["listen", "--listen", "loop://", "--seconds", "0.01"])[0] == 0
    assert Path(files["gain"]).exists()
