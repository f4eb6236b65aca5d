"""`hexmigrate pack` of an ELF packs what GNU objcopy packs: the allocated sections, not the
bytes of a loadable segment that also maps the ELF and program headers."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from elftools.elf.elffile import ELFFile
from intelhex import IntelHex

from hexmigrate.cli import main
from hexmigrate.errors import ModuleSourceError
from hexmigrate.image import ModuleImage
from hexmigrate.records import Segment
from module_sdk.build import COMPILE_FLAGS, EXAMPLES_DIR, GCC, OBJCOPY, SDK_DIR, TARGET

UNALIGNED_TEXT = 0x10074
"""Not a page boundary: the default linker script maps the headers into the first segment."""

needs_tools = pytest.mark.skipif(
    shutil.which(GCC) is None or shutil.which(OBJCOPY) is None,
    reason=f"needs {GCC} and {OBJCOPY}",
)


@pytest.fixture(scope="module")
def header_mapped_elf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gain.c compiled with the SDK's flags and linked with the toolchain's default script at an
    address that is not page aligned, as a user who skips module.ld would."""
    out = tmp_path_factory.mktemp("header_mapped")
    source = EXAMPLES_DIR / "gain.c"
    obj, elf = out / "gain.o", out / "gain.elf"
    compile_command = [GCC, *COMPILE_FLAGS, f"-I{SDK_DIR}", "-c", str(source), "-o", str(obj)]
    subprocess.run(compile_command, check=True, capture_output=True)
    link = [GCC, *TARGET, "-nostdlib", "-Wl,--emit-relocs", "-Wl,--build-id=none"]
    link += [f"-Wl,-Ttext=0x{UNALIGNED_TEXT:x}", "-e", "module_init", str(obj), "-o", str(elf)]
    subprocess.run(link, check=True, capture_output=True)
    return elf


def objcopy(elf: Path, kind: str) -> Path:
    out = elf.with_suffix(f".objcopy.{kind}")
    subprocess.run([OBJCOPY, "-O", kind, str(elf), str(out)], check=True, capture_output=True)
    return out


def pack(elf: Path, tmp_path: Path) -> ModuleImage:
    out = tmp_path / "packed.hex"
    assert main(["pack", str(elf), "-o", str(out)]) == 0
    return ModuleImage.read(out)


@needs_tools
def test_the_first_loadable_segment_maps_the_elf_header(header_mapped_elf):
    with header_mapped_elf.open("rb") as stream:
        elf = ELFFile(stream)
        first = next(s for s in elf.iter_segments() if s["p_type"] == "PT_LOAD")
        assert first["p_offset"] == 0
        assert first["p_filesz"] > elf["e_ehsize"] + elf["e_phnum"] * elf["e_phentsize"]
        assert first["p_paddr"] < UNALIGNED_TEXT


@needs_tools
def test_pack_holds_the_bytes_objcopy_binary_writes(header_mapped_elf, tmp_path):
    image = pack(header_mapped_elf, tmp_path)
    assert image.link_base == UNALIGNED_TEXT
    assert image.data == objcopy(header_mapped_elf, "binary").read_bytes()
    assert not image.data.startswith(b"\x7fELF")


@needs_tools
def test_pack_agrees_with_objcopy_ihex_at_every_address_objcopy_writes(header_mapped_elf, tmp_path):
    image = pack(header_mapped_elf, tmp_path)
    reference = IntelHex(str(objcopy(header_mapped_elf, "ihex")))
    assert reference.minaddr() == image.link_base
    assert reference.maxaddr() == image.link_base + image.size - 1
    for address in reference.addresses():
        assert image.data[address - image.link_base] == reference[address]


def test_sections_far_apart_are_refused_without_filling_memory():
    far_apart = [Segment(0x0, b"\x13\x00\x00\x00"), Segment(0xF000_0000, b"\x13\x00\x00\x00")]
    with pytest.raises(ModuleSourceError, match="expected sections spanning at most"):
        ModuleImage.from_segments("far", far_apart, (), 0x0)
