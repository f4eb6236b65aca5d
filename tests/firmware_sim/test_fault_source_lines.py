"""A guest fault, a watchdog stop and a refused `on` name the module, the function and the
source line, from the module's ELF (beside its HEX file, or given with --elf) when that ELF is
the build that was installed; `firmware-sim run` exits 1 when a PBO ended in ERROR."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from firmware_sim.cli.command import main
from hexmigrate.elf import image_from_elf
from module_sdk.build import build_module

GUEST = Path(__file__).parent / "guests" / "faulty.c"


def marked_line(marker: str, source: Path = GUEST) -> int:
    """The number of the source line that holds `/* MARK: marker */`."""
    lines = source.read_text().splitlines()
    return next(n for n, line in enumerate(lines, 1) if f"/* MARK: {marker} */" in line)


@pytest.fixture(scope="module")
def module(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """faulty.hex with faulty.elf beside it."""
    out = tmp_path_factory.mktemp("faulty")
    built = build_module(GUEST, out)
    image_from_elf(built.elf).write(out / "faulty.hex")
    return out / "faulty.hex"


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(["run", *argv, "--cycles", "2"])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_a_memory_fault_names_the_function_file_and_line(module, capsys):
    status, out, err = run(capsys, "--module", str(module), "--set", "faulty.mode=1")
    place = f"by the instruction at 0x08000038 in faulty_cycle (faulty.c:{marked_line('write')})"
    assert status == 1
    assert place in out  # the report's log
    assert err.startswith("error: PBO(s) faulty ended in ERROR: faulty: cycle faulted: ")
    assert err.rstrip().endswith(place)


def test_a_watchdog_stop_names_the_line_where_the_budget_ran_out(module, capsys):
    status, _, err = run(
        capsys, "--module", str(module), "--set", "faulty.mode=2", "--budget", "1000"
    )
    assert status == 1
    assert "watchdog: instruction budget of 1000 exhausted at 0x" in err
    assert err.rstrip().endswith(f"in faulty_cycle (faulty.c:{marked_line('spin')})")


def test_a_refused_on_names_the_function_and_its_line(module, capsys):
    status, _, err = run(capsys, "--module", str(module), "--set", "faulty.refuse=1")
    assert status == 1
    assert "PBO 'faulty': on returned -3 in faulty_on (faulty.c:" in err
    line = int(err.split("faulty_on (faulty.c:")[1].split(")")[0])
    assert marked_line("on") <= line <= marked_line("on") + 3  # inside faulty_on


def test_an_elf_given_with_elf_is_used_for_a_module_elsewhere(module, tmp_path, capsys):
    alone = tmp_path / "alone" / "faulty.hex"
    alone.parent.mkdir()
    shutil.copy(module, alone)
    status, _, err = run(capsys, "--module", str(alone), "--set", "faulty.mode=1")
    assert status == 1 and " in faulty_cycle" not in err  # no ELF at hand: no source line
    elf = module.with_suffix(".elf")
    status, _, err = run(
        capsys, "--module", str(alone), "--elf", str(elf), "--set", "faulty.mode=1"
    )
    assert status == 1 and f"in faulty_cycle (faulty.c:{marked_line('write')})" in err


def test_an_elf_of_another_build_gives_no_line(module, tmp_path, capsys):
    edited = tmp_path / "faulty.c"
    edited.write_text(GUEST.read_text().replace("0x20000010u", "0x20000014u"))
    other = build_module(edited, tmp_path / "other").elf
    alone = tmp_path / "faulty.hex"
    shutil.copy(module, alone)
    status, out, err = run(
        capsys, "--module", str(alone), "--elf", str(other), "--set", "faulty.mode=1"
    )
    assert status == 1
    assert " in faulty_cycle" not in err
    assert f"{other} is not the build of module 'faulty' that is installed" in out


def test_a_run_whose_pbos_all_end_well_exits_0(module, capsys):
    assert run(capsys, "--module", str(module))[0] == 0
