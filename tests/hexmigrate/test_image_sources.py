"""Module images from linker output: ELF and map routes, interoperability, relocation."""

from __future__ import annotations

import io
import itertools
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from elftools.elf.elffile import ELFFile
from intelhex import IntelHex

from hexmigrate import descriptor as abi
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import HexError, MapMismatchError, ModuleSourceError
from hexmigrate.image import ModuleImage
from hexmigrate.mapfile import image_from_map, parse_map
from hexmigrate.records import decode


def loadable_bytes(elf_path: Path) -> dict[int, int]:
    """Address to byte for every byte of the ELF's loadable segments."""
    memory: dict[int, int] = {}
    with elf_path.open("rb") as stream:
        for segment in ELFFile(stream).iter_segments():
            if segment["p_type"] == "PT_LOAD":
                data = segment.data()[: segment["p_filesz"]]
                start = segment["p_paddr"]
                memory.update(zip(range(start, start + len(data)), data, strict=True))
    return memory


def test_elf_and_map_routes_give_the_same_hex(example):
    from_elf = image_from_elf(example.elf)
    from_map = image_from_map(example.bin, example.map)
    assert from_elf == from_map
    for record_size in (16, 32):
        assert from_elf.to_hex(record_size) == from_map.to_hex(record_size)


def test_relocations_are_exactly_the_descriptor_methods(example):
    image = image_from_elf(example.elf)
    descriptor = parse_map(example.map.read_text()).output_sections[".pbo_descriptor"]
    methods_end = descriptor.address + descriptor.size
    assert image.relocations == tuple(range(methods_end - 9 * 4, methods_end, 4))
    assert all(image.word_at(location) in image.symbols for location in image.relocations)
    assert image.symbols[image.init] == "module_init"


def test_objcopy_hex_parses_to_the_elf_loadable_bytes(example):
    content = decode(example.objcopy_hex.read_text())
    parsed = {
        segment.address + offset: byte
        for segment in content.segments
        for offset, byte in enumerate(segment.data)
    }
    expected = loadable_bytes(example.elf)
    assert parsed == {address: expected[address] for address in parsed}
    assert set(parsed) <= set(expected)
    # objcopy leaves section padding out; what it omits is padding the ELF route keeps.
    image = image_from_elf(example.elf)
    assert len(expected) == image.size


@pytest.mark.parametrize("record_size", [16, 32])
def test_intelhex_loads_our_data_records_to_the_same_bytes(example, record_size):
    image = image_from_elf(example.elf)
    standard = "\n".join(
        line for line in image.to_hex(record_size).splitlines() if line[7:9] not in ("07", "08")
    )
    loaded = IntelHex(io.StringIO(standard))
    assert loaded.minaddr() == image.link_base
    assert loaded.tobinstr(start=image.link_base, size=image.size) == image.data


def test_relocation_to_two_bases_differs_exactly_at_pointer_words(example):
    image = image_from_elf(example.elf)
    first, second = 0x0002_0000, 0x0004_0300
    low, high = image.relocate(first), image.relocate(second)
    differing = [offset for offset in range(image.size) if low[offset] != high[offset]]
    touched = {location - image.link_base + i for location in image.relocations for i in range(4)}
    assert set(differing) <= touched
    for location in image.relocations:
        offset = location - image.link_base
        low_word = int.from_bytes(low[offset : offset + 4], "little")
        high_word = int.from_bytes(high[offset : offset + 4], "little")
        assert high_word - low_word == second - first
        assert low_word == image.word_at(location) + first - image.link_base


def test_relocation_at_link_base_is_identity_and_wraps_modulo_2_32():
    image = ModuleImage(
        "m", 0x10000, (0xFFFFFFF0).to_bytes(4, "little") + bytes(4), (0x10000,), 0x10004
    )
    assert image.relocate(0x10000) == image.data
    assert image.relocate(0x10020)[:4] == (0x10).to_bytes(4, "little")
    with pytest.raises(ValueError, match="expected a load base"):
        image.relocate((1 << 32) - 4)


def test_written_module_reads_back_identically(example, tmp_path):
    image = image_from_elf(example.elf)
    path = tmp_path / f"{example.name}.hex"
    image.write(path, 32)
    assert ModuleImage.read(path) == image
    assert not list(tmp_path.glob("*.partial"))


def test_not_an_elf_file(tmp_path):
    path = tmp_path / "junk.elf"
    path.write_bytes(b"this is not an ELF file at all")
    with pytest.raises(ModuleSourceError, match=r"junk\.elf: expected an ELF file"):
        image_from_elf(path)


def test_host_elf_is_refused(tmp_path):
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no host C compiler to make a non-RISC-V ELF")
    source = tmp_path / "host.c"
    source.write_text("int host(void) { return 1; }\n")
    subprocess.run([compiler, "-c", str(source), "-o", str(tmp_path / "host.o")], check=True)
    with pytest.raises(ModuleSourceError, match="expected a 32-bit little-endian RISC-V ELF, got"):
        image_from_elf(tmp_path / "host.o")


def test_missing_init_symbol_names_the_option(example):
    with pytest.raises(ModuleSourceError, match=r"expected a symbol 'nope' .*--init"):
        image_from_elf(example.elf, init_symbol="nope")


def test_map_without_memory_map_part(example, tmp_path):
    bad_map = tmp_path / "bad.map"
    bad_map.write_text("Memory Configuration\n")
    with pytest.raises(ModuleSourceError, match=r"bad\.map: expected a GNU ld map file"):
        image_from_map(example.bin, bad_map)


def test_map_with_a_truncated_binary_is_refused(example, tmp_path):
    short = tmp_path / "short.bin"
    short.write_bytes(example.bin.read_bytes()[:64])
    with pytest.raises(MapMismatchError, match="does the binary belong to this map"):
        image_from_map(short, example.map)


def test_map_without_link_base_symbol(example, tmp_path):
    stripped = tmp_path / "stripped.map"
    stripped.write_text(example.map.read_text().replace("__module_start", "__elsewhere"))
    with pytest.raises(ModuleSourceError, match="expected the symbol '__module_start'"):
        image_from_map(example.bin, stripped)


def test_every_swap_of_two_lines_in_a_real_module_is_caught_or_harmless(example_builds):
    image = image_from_elf(example_builds["gain"].elf)
    lines = image.to_hex().splitlines()
    harmless = []
    for first, second in itertools.combinations(range(len(lines)), 2):
        swapped = lines.copy()
        swapped[first], swapped[second] = swapped[second], swapped[first]
        try:
            result = ModuleImage.from_hex("\n".join(swapped), image.name)
        except HexError:
            continue
        assert result == image, f"swapping lines {first + 1} and {second + 1} changed the module"
        harmless.append({lines[first][7:9], lines[second][7:9]})
    # Only records that carry absolute addresses (07, 08) or precede all data (04) trade places.
    assert all(kinds <= {"07", "08", "04"} for kinds in harmless)


def test_the_elf_route_holds_the_bytes_objcopy_writes_padding_included(example):
    """The gap before the 4-byte aligned descriptor is zero, as in objcopy's raw binary."""
    assert image_from_elf(example.elf).data == example.bin.read_bytes()


def test_the_descriptor_search_decodes_a_descriptor_s_bytes_not_the_rest_of_the_image(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Each aligned ``PBO1`` is tried: handing each try the rest of the image made an image
    full of them quadratic to read (16 MiB: over half an hour)."""
    decode = abi.Descriptor.decode
    lengths: list[int] = []

    def recording(data: bytes) -> abi.Descriptor:
        lengths.append(len(data))
        return decode(data)

    monkeypatch.setattr(abi.Descriptor, "decode", recording)
    data = (b"PBO1" + bytes(4)) * 4096  # magics of no ABI this reads
    ModuleImage("magics", 0x10000, data, (), 0x10000)
    assert len(lengths) == 4096 and max(lengths) <= abi.SIZE


def test_reading_a_module_from_a_pipe_or_a_device_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "gain.hex"
    os.mkfifo(fifo)  # no writer: a plain open would wait for one forever
    for path in (fifo, Path(os.devnull)):
        with pytest.raises(ModuleSourceError, match="expected a regular module file") as caught:
            ModuleImage.read(path)
        assert str(caught.value).startswith(f"{path}: ")
