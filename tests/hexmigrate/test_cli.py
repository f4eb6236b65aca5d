"""The `hexmigrate` command as a user runs it: output, exit codes, error lines."""

from __future__ import annotations

import json
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from hexmigrate.descriptor import METHODS_OFFSET
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage

HEXMIGRATE = Path(sys.executable).with_name("hexmigrate")


def run(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hexmigrate", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
    )


@pytest.fixture
def packed(example_builds, tmp_path) -> Path:
    out = tmp_path / "gain.hex"
    result = run("pack", example_builds["gain"].elf, "-o", out)
    assert result.returncode == 0, result.stderr
    return out


def test_console_script_is_installed():
    result = subprocess.run([HEXMIGRATE, "--help"], capture_output=True, text=True, check=False)
    assert result.returncode == 0
    for command in ("pack", "inspect", "verify", "relocate"):
        assert command in result.stdout


def test_pack_from_elf_and_from_map_agree(example_builds, tmp_path, packed):
    gain = example_builds["gain"]
    from_map = tmp_path / "from-map.hex"
    result = run("pack", "--map", gain.map, "--bin", gain.bin, "-o", from_map)
    assert result.returncode == 0, result.stderr
    assert from_map.read_bytes() == packed.read_bytes()
    both = run("pack", gain.elf, "--map", gain.map, "--bin", gain.bin, "-o", tmp_path / "b.hex")
    assert both.returncode == 0, both.stderr
    size = ModuleImage.read(packed).size
    assert f"module gain, {size} bytes at 0x00010000, 9 relocations" in result.stdout


def test_pack_refuses_routes_that_disagree(example_builds, tmp_path):
    gain, average = example_builds["gain"], example_builds["moving_average"]
    result = run(
        "pack", gain.elf, "--map", average.map, "--bin", average.bin, "-o", tmp_path / "x.hex"
    )
    assert result.returncode == 1
    assert result.stderr.startswith("error: the ELF and the map route disagree on the data")
    assert not (tmp_path / "x.hex").exists()


def test_pack_record_size_32(example_builds, tmp_path):
    out = tmp_path / "gain.hex"
    assert run("pack", example_builds["gain"].elf, "--record-size", "32", "-o", out).returncode == 0
    counts = {line[1:3] for line in out.read_text().splitlines() if line[7:9] == "00"}
    assert "20" in counts and "10" not in counts
    assert ModuleImage.read(out) == image_from_elf(example_builds["gain"].elf)


def test_inspect_text_names_every_slot(packed):
    result = run("inspect", packed)
    assert result.returncode == 0, result.stderr
    assert "relocations 9 (record 07)" in result.stdout
    image = ModuleImage.read(packed)
    descriptor = image.relocations[0] - METHODS_OFFSET
    assert f"descriptor  at 0x{descriptor:08X}: 'gain', ABI 1" in result.stdout
    assert "port x            in       scalar 4 bytes (1x1 of 4-byte elements)" in result.stdout
    for slot in ("init", "on", "cycle", "off", "kill", "error", "clear", "evaluate", "estimate"):
        assert f"descriptor.{slot}" in result.stdout
    assert f"{len(image.flash_blocks())} block(s) of 256 bytes" in result.stdout


def test_inspect_json(packed):
    result = run("inspect", packed, "--json")
    report = json.loads(result.stdout)
    image = ModuleImage.read(packed)
    assert report["link_base"] == image.link_base == 0x10000
    assert report["size"] == image.size
    assert report["init"] == image.init
    assert [r["location"] for r in report["relocations"]] == list(image.relocations)
    assert all(r["target"] == image.word_at(r["location"]) for r in report["relocations"])
    blocks = -(-image.size // 256)
    assert report["flash_blocks"] == [0x10000 + 256 * i for i in range(blocks)]
    assert report["descriptor"]["name"] == "gain"
    assert report["records"] == {"00": -(-image.size // 16), "01": 1, "04": 1, "07": 9, "08": 1}


def test_verify_exit_codes_and_error_line(packed, data_dir):
    assert run("verify", packed).returncode == 0
    bad = data_dir / "bad_checksum.hex"
    result = run("verify", bad)
    assert result.returncode == 1
    assert result.stderr == f"error: {bad}:5: expected checksum 68, got 00\n"
    assert result.stdout == ""


def test_debug_shows_the_traceback(data_dir):
    result = run("--debug", "verify", data_dir / "bad_checksum.hex")
    assert result.returncode == 1
    assert "Traceback" in result.stderr
    assert "ChecksumError" in result.stderr


def test_relocate_writes_flash_bytes(packed, tmp_path):
    out = tmp_path / "gain.bin"
    result = run("relocate", packed, "--base", "0x20000", "-o", out)
    assert result.returncode == 0, result.stderr
    assert out.read_bytes() == ModuleImage.read(packed).relocate(0x20000)
    crc = zlib.crc32(out.read_bytes())
    assert f"9 pointers moved by +0x10000, CRC-32 0x{crc:08X} (as a node holding it there " in (
        result.stdout
    )


def test_relocate_refuses_a_base_past_4_gib(packed, tmp_path):
    result = run("relocate", packed, "--base", "0xFFFFFF00", "-o", tmp_path / "x.bin")
    assert result.returncode == 1
    highest = (1 << 32) - ModuleImage.read(packed).size
    assert f"expected a load base from 0x0 to 0x{highest:08X}" in result.stderr
    assert not (tmp_path / "x.bin").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["relocate", "{good}", "--base", "twelve", "-o", "x.bin"],
            "expected an address like 0x20000, got 'twelve'",
        ),
        (
            ["send", "{good}", "--base", "0xFFFFFFFF", "--to", "loop://"],
            "argument --base: expected an address from 0 to 0xFFFFFFFE (0xFFFFFFFF stands for",
        ),
        (["pack", "--map", "{good}", "-o", "x.hex"], "--map and --bin go together"),
        (["pack", "-o", "x.hex"], "expected MODULE.elf, or --map MODULE.map --bin MODULE.bin"),
        (["pack", "{good}"], "the following arguments are required: -o/--output"),
        (["inspect", "{missing}"], "argument FILE.hex: {missing}: No such file or directory"),
        (["verify", "{folder}"], "argument FILE.hex: expected a regular file, got {folder}"),
    ],
)
def test_usage_errors_exit_2(args, message, data_dir, tmp_path):
    names = {
        "good": data_dir / "good_module.hex",
        "missing": tmp_path / "m.hex",
        "folder": tmp_path,
    }
    result = run(*(arg.format(**names) for arg in args), cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith("usage: hexmigrate ")
    assert message.format(**names) in result.stderr
    assert "Traceback" not in result.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("command", "request_name"),
    [(["ping"], "Ping"), (["ls"], "ListModules"), (["rm", "gain"], "Remove")],
)
def test_a_node_that_never_answers_is_one_error_line(command, request_name):
    result = run(*command, "--to", "faulty+loop://#drop=1", "--timeout", "0.02", "--retries", "1")
    assert result.returncode == 1
    assert result.stderr.startswith(f"error: no answer to {request_name} after ")
    assert result.stderr.count("\n") == 1
    assert result.stdout == ""


def test_a_send_nobody_answers_is_one_error_line(packed):
    result = run(
        "send", packed, "--to", "faulty+loop://#drop=1", "--timeout", "0.02", "--retries", "1"
    )
    assert result.returncode == 1
    assert result.stderr.splitlines()[-1].startswith("error: no answer to ")
    assert "Traceback" not in result.stderr
    assert result.stdout == ""
