"""Hostile command lines: whatever the options and files, `hexmigrate` answers with exit status
0, 1 (one ``error:`` line) or 2 (a usage error), never a traceback, a hang or an unbounded read.

Links are only ever URLs that fail at once (malformed, or a scheme nobody knows): the fuzz opens
no device and waits for no node.
"""

from __future__ import annotations

import os
import random
import shutil
import string
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from commandline.arguments import DEFAULT_MAX_FILE_BYTES
from hexmigrate.cli import main

FUZZ = settings(
    max_examples=150,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

ODD_NUMBERS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "1e309",
    "-1",
    "0",
    "0.0",
    "1e-320",
    "0x10",
    "0b11",
    "1_000",
    "99999999999999999999999",
    "0xFFFFFFFF",
    "0x100000000",
    "4294967296",
    "-0x1",
    "3",
    "16",
    "32",
    "0.5",
    "1e3",
]
NUMBERS = st.one_of(
    st.sampled_from([*ODD_NUMBERS, "", " "]),
    st.integers().map(str),
    st.floats().map(repr),
    st.text(max_size=12),
)
KNOWN_SCHEMES = {"", "serial", "loop", "socket", "tcp-listen", "can"}
MALFORMED_URLS = [
    "",
    "nope",
    "bad://x",
    "http://127.0.0.1:1",
    "serial:",
    "socket://",
    "socket://127.0.0.1",
    "socket://127.0.0.1:99999",
    "tcp-listen://0.0.0.0:99999",
    "can://",
    "can://nowhere/x",
    "faulty+",
    "faulty+bad://x#drop=1",
    "faulty+loop://#drop=nan",
    "faulty+loop://#nonsense=1",
]
URLS = st.one_of(
    st.sampled_from(MALFORMED_URLS),
    st.text(alphabet=string.ascii_letters + string.digits + "-._~@!", max_size=20),
    st.from_regex(r"[a-z][a-z0-9+.-]{0,8}:[ -~]{0,16}", fullmatch=True).filter(
        lambda url: url.partition(":")[0] not in KNOWN_SCHEMES and "faulty" not in url
    ),
)
NAMES = st.one_of(st.sampled_from(["gain", "", "a b", "x" * 17, "é", "-x"]), st.text(max_size=20))
CONTROL = ["ps", "start", "stop", "set", "rate", "connect", "disconnect", "watch"]
CONTROL_ARGUMENTS = st.one_of(
    st.sampled_from(
        ["gain.k=2", "gain.k=nan", "gain.k=1e999", "a.b=c.d", "a.b=c", "=", "x" * 200, "gain=50"]
    ),
    st.sampled_from(["gain=0", "gain=-1", "gain=inf", "gain=4294968", "=5"]),
    st.text(max_size=30),
)
"""What set, rate, connect and disconnect take, right and wrong."""


@dataclass(frozen=True)
class Files:
    """Files of every kind a path option can name, made once per module."""

    good: Path
    elf: Path
    map: Path
    bin: Path
    out: Path
    folder: Path
    fifo: Path
    huge: Path
    empty: Path
    noise: Path
    missing: Path

    def inputs(self) -> list[str]:
        """Paths where a command expects a file to read."""
        kinds = [self.good, self.elf, self.map, self.bin, self.folder, self.fifo, self.huge]
        kinds += [self.empty, self.noise, self.missing]
        return [*map(str, kinds), "/dev/zero", "/dev/null", "", "a\0b"]

    def outputs(self) -> list[str]:
        """Paths where a command writes: never a device (a rename would replace it)."""
        return [*map(str, (self.out, self.folder, self.fifo, self.missing / "x.hex")), "a\0b"]


@pytest.fixture(scope="module")
def files(tmp_path_factory, example_builds) -> Files:
    root = tmp_path_factory.mktemp("hostile")
    gain = example_builds["gain"]
    for source in (gain.elf, gain.map, gain.bin, gain.objcopy_hex):
        shutil.copy(source, root / source.name)
    fifo = root / "fifo"
    os.mkfifo(fifo)
    huge = root / "huge.hex"
    with huge.open("wb") as stream:
        stream.truncate(DEFAULT_MAX_FILE_BYTES + 1)  # sparse: no disk used
    (root / "empty.hex").write_bytes(b"")
    (root / "noise.hex").write_bytes(random.Random(12).randbytes(4096))
    (root / "folder").mkdir()
    good = root / "good.hex"
    assert main(["pack", str(root / gain.elf.name), "-o", str(good)]) == 0
    return Files(
        good=good,
        elf=root / gain.elf.name,
        map=root / gain.map.name,
        bin=root / gain.bin.name,
        out=root / "out.hex",
        folder=root / "folder",
        fifo=fifo,
        huge=huge,
        empty=root / "empty.hex",
        noise=root / "noise.hex",
        missing=root / "missing",
    )


def run_hostile(argv: list[str], capsys: pytest.CaptureFixture[str]) -> int:
    """Run the command in this process; only SystemExit(2) may escape main."""
    try:
        status = main(argv)
    except SystemExit as exit_info:
        status = exit_info.code
        assert status == 2, argv
    captured = capsys.readouterr()
    assert status in (0, 1, 2), argv
    assert "Traceback" not in captured.err, (argv, captured.err)
    if status == 1:
        assert captured.err.startswith("error: ") and captured.err.count("\n") == 1, captured.err
    return status


def options(draw: st.DrawFn, names: list[str], values: st.SearchStrategy[str]) -> list[str]:
    """Some of `names`, each with a drawn value."""
    chosen = draw(st.lists(st.sampled_from(names), unique=True, max_size=len(names)))
    return [item for name in chosen for item in (name, draw(values))]


@st.composite
def file_commands(draw: st.DrawFn, files: Files) -> list[str]:
    """pack, inspect, verify and relocate with hostile files and numbers."""
    inputs, outputs = st.sampled_from(files.inputs()), st.sampled_from(files.outputs())
    command = draw(st.sampled_from(["pack", "inspect", "verify", "relocate"]))
    if command == "pack":
        argv = ["pack", *draw(st.lists(inputs, max_size=1))]
        argv += options(draw, ["--map", "--bin"], inputs)
        argv += options(draw, ["--record-size"], NUMBERS)
        argv += options(draw, ["--init"], NAMES)
        return [*argv, "-o", draw(outputs)]
    if command == "relocate":
        return ["relocate", draw(inputs), "--base", draw(NUMBERS), "-o", draw(outputs)]
    return [command, draw(inputs), *draw(st.lists(st.just("--json"), max_size=1))]


@st.composite
def node_commands(draw: st.DrawFn, files: Files) -> list[str]:
    """send, ping, ls, rm and the control commands with hostile names, numbers and links that
    fail at once."""
    command = draw(st.sampled_from(["send", "ping", "ls", "rm", *CONTROL]))
    argv = [command]
    if command in ("start", "stop"):
        argv += [draw(NAMES)]
    if command in ("set", "rate", "connect", "disconnect"):
        argv += [draw(CONTROL_ARGUMENTS)]
    if command == "watch":
        argv += [item for _ in range(draw(st.integers(0, 3))) for item in ("--port", draw(NAMES))]
        argv += options(draw, ["--seconds", "--period"], NUMBERS)
        argv += draw(st.lists(st.just("--csv"), max_size=1))
    if command == "send":
        argv += [draw(st.sampled_from(files.inputs()))]
        argv += options(draw, ["--base", "--reconnects"], NUMBERS)
        argv += draw(st.lists(st.just("--quiet"), max_size=1))
    if command == "rm":
        argv += [draw(NAMES)]
    argv += options(draw, ["--window", "--timeout", "--retries"], NUMBERS)
    argv += options(draw, ["--mode"], st.sampled_from(["binary", "hex", "text", ""]))
    return [*argv, "--to", draw(URLS)]


@FUZZ
@given(data=st.data())
def test_file_commands_refuse_hostile_options_cleanly(files, capsys, data):
    argv = data.draw(file_commands(files))
    run_hostile(argv, capsys)
    assert not files.missing.exists()


@FUZZ
@given(data=st.data())
def test_node_commands_refuse_hostile_options_cleanly(files, capsys, data):
    argv = data.draw(node_commands(files))
    assert run_hostile(argv, capsys) != 0


@FUZZ
@given(st.lists(st.tuples(st.integers(0, 1 << 14), st.integers(0, 255)), min_size=1, max_size=8))
def test_pack_of_a_damaged_elf_is_an_error_line_at_worst(files, capsys, tmp_path_factory, flips):
    damaged = bytearray(files.elf.read_bytes())
    for offset, value in flips:
        damaged[offset % len(damaged)] = value
    path = files.folder.parent / "damaged.elf"
    path.write_bytes(bytes(damaged))
    run_hostile(["pack", str(path), "-o", str(files.out)], capsys)


@FUZZ
@given(st.binary(max_size=512))
def test_pack_of_noise_after_an_elf_magic_is_an_error_line(files, capsys, noise):
    path = files.folder.parent / "noise.elf"
    path.write_bytes(b"\x7fELF\x01\x01\x01" + noise)
    assert run_hostile(["pack", str(path), "-o", str(files.out)], capsys) == 1


@FUZZ
@given(st.lists(st.tuples(st.integers(0, 1 << 16), st.text(max_size=12)), min_size=1, max_size=6))
def test_pack_of_a_damaged_map_is_an_error_line_at_worst(files, capsys, edits):
    text = files.map.read_text()
    for offset, insert in edits:
        position = offset % (len(text) + 1)
        text = text[:position] + insert + text[position + len(insert) :]
    path = files.folder.parent / "damaged.map"
    path.write_text(text)
    run_hostile(["pack", "--map", str(path), "--bin", str(files.bin), "-o", str(files.out)], capsys)


def test_a_map_number_that_is_not_hexadecimal_names_its_line(files, capsys):
    lines = files.map.read_text().splitlines()
    # ld puts the address and size of a long section name on the next line
    number = 1 + next(i for i, line in enumerate(lines, 1) if line == ".pbo_descriptor")
    lines[number - 1] = lines[number - 1].replace("0x0", "0xZ", 1)
    path = files.folder.parent / "bad_number.map"
    path.write_text("\n".join(lines) + "\n")
    argv = ["pack", "--map", str(path), "--bin", str(files.bin), "-o", str(files.out)]
    assert main(argv) == 1
    wrong = lines[number - 1].split()[0]
    assert capsys.readouterr().err == (
        f"error: {path}:{number}: expected a hexadecimal number like 0x00010000, got {wrong!r}\n"
    )


@pytest.mark.parametrize(
    ("option", "value"),
    [
        *(("--timeout", value) for value in ("nan", "inf", "-inf", "0", "-1", "1e309", "601")),
        *(("--retries", value) for value in ("0", "-1", "1001", "1.5", "nan")),
        *(("--window", value) for value in ("0", "257", "nan")),
        *(("--reconnects", value) for value in ("-1", "101", "inf")),
        *(("--base", value) for value in ("-1", "0x100000000", "nan", "1e3")),
    ],
)
def test_a_number_out_of_range_is_a_usage_error_before_any_link_opens(files, capsys, option, value):
    argv = ["send", str(files.good), option, value, "--to", "nope"]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert f"argument {option}: expected " in capsys.readouterr().err


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("/dev/zero", "expected a regular file, got /dev/zero (a device)"),
        ("fifo", "expected a regular file, got {path} (a pipe)"),
        ("folder", "expected a regular file, got {path} (a directory)"),
        ("huge", f"expected a file of at most {DEFAULT_MAX_FILE_BYTES:,} bytes, got {{path}}"),
    ],
)
@pytest.mark.parametrize("command", [["inspect"], ["verify"], ["pack"], ["pack", "--bin"]])
def test_a_file_that_is_not_a_regular_bounded_file_is_a_usage_error(
    files, capsys, kind, message, command
):
    path = kind if kind.startswith("/") else str(getattr(files, kind))
    with pytest.raises(SystemExit) as exit_info:
        main([*command, path, "-o", str(files.out)] if command[0] == "pack" else [*command, path])
    assert exit_info.value.code == 2
    assert message.format(path=path) in capsys.readouterr().err
