"""`hexmigrate pack` and `verify` refuse what a node would refuse or run wrongly: each bad
input is built for real with the SDK's toolchain, or from a real module's image."""

from __future__ import annotations

import contextlib
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hexmigrate import descriptor as abi
from hexmigrate.checks import check_module, verify_file
from hexmigrate.cli import main
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import (
    CompressedCodeError,
    InitAlignmentError,
    MapMismatchError,
    MissingRelocationsError,
    ModuleCheckError,
    NameLengthError,
    PointerAlignmentError,
)
from hexmigrate.image import ModuleImage, find_descriptor
from hexmigrate.mapfile import image_from_map
from module_sdk.build import (
    COMPILE_FLAGS,
    EXAMPLES_DIR,
    GCC,
    LINKER_SCRIPT,
    OBJCOPY,
    SDK_DIR,
    TARGET,
    ModuleBuild,
)

pytestmark = pytest.mark.skipif(
    shutil.which(GCC) is None or shutil.which(OBJCOPY) is None,
    reason=f"needs {GCC} and {OBJCOPY}",
)

RV32IMC = ["-march=rv32imc", "-mabi=ilp32"]
SIXTEEN = "a_sixteen_chars_"


def build(
    source: Path,
    out: Path,
    *,
    target: list[str] = TARGET,
    emit_relocs: bool = True,
    optimise: str = "-Os",
    werror: bool = True,
    compile_flags: list[str] = COMPILE_FLAGS,
) -> ModuleBuild:
    """Compile and link `source` as module_sdk/build.py does, with one thing changed."""
    out.mkdir(parents=True, exist_ok=True)
    name = source.stem
    obj, elf, map_file, binary = (out / f"{name}{ext}" for ext in (".o", ".elf", ".map", ".bin"))
    flags = [*target, *(f for f in compile_flags if f not in TARGET)]
    flags = [optimise if f == "-Os" else f for f in flags if werror or f != "-Werror"]
    compile_command = [GCC, *flags, f"-I{SDK_DIR}", "-c", str(source), "-o", str(obj)]
    subprocess.run(compile_command, check=True, capture_output=True)
    link = [GCC, *target, "-nostdlib", "-T", str(LINKER_SCRIPT), f"-Wl,-Map={map_file}"]
    link += ["-Wl,--emit-relocs"] if emit_relocs else []
    link += ["-Wl,--build-id=none", str(obj), "-o", str(elf)]
    subprocess.run(link, check=True, capture_output=True)
    subprocess.run([OBJCOPY, "-O", "binary", str(elf), str(binary)], check=True)
    return ModuleBuild(name, elf, map_file, binary, out / f"{name}.objcopy.hex")


def hex_of_binary(build: ModuleBuild, out: Path, **changes: object) -> Path:
    """A module file of a build's raw bytes, its 07 records at the descriptor's method words
    (as `pack` would give), with `changes` (relocations, init) to the image."""
    data = build.bin.read_bytes()
    plain = ModuleImage(build.name, 0x10000, data, (), 0x10000)
    found = find_descriptor(plain)
    assert found is not None
    address, descriptor = found
    slots = [
        address + abi.METHODS_OFFSET + 4 * index
        for index, target in enumerate(descriptor.methods.values())
        if target
    ]
    fields = {"relocations": tuple(slots), "init": 0x10000} | changes
    image = ModuleImage(build.name, 0x10000, data, fields["relocations"], fields["init"])
    path = out / f"{build.name}.hex"
    image.write(path)
    return path


def refuse(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run the command line, expect exit status 1 and give its error line."""
    assert main(argv) == 1
    return capsys.readouterr().err.strip()


# A 07 location unaligned or straddling a flash block.


def test_verify_refuses_an_unaligned_pointer_word_naming_the_record_line(example, tmp_path):
    path = hex_of_binary(example, tmp_path, relocations=(0x10102,))
    with pytest.raises(PointerAlignmentError) as caught:
        verify_file(path)
    assert str(caught.value).startswith(f"{path}:1: ")
    assert "4-byte aligned address, got 0x00010102" in str(caught.value)


def test_verify_refuses_a_pointer_word_straddling_two_flash_blocks(example, tmp_path, capsys):
    path = hex_of_binary(example, tmp_path, relocations=(0x100FE,))
    message = refuse(["verify", str(path)], capsys)
    assert message.startswith(f"error: {path}:1: ")
    assert "0x000100FE: it straddles two 256-byte flash blocks (offset 254" in message


def test_verify_refuses_an_07_record_on_a_word_that_is_no_pointer(example, tmp_path, capsys):
    path = hex_of_binary(example, tmp_path, relocations=(0x10000,))
    message = refuse(["verify", str(path)], capsys)
    assert message.startswith(f"error: {path}:1: expected the word at 0x00010000 named by the 07")
    assert "to hold an address inside the image (0x00010000..0x0001045F), got 0x" in message


def test_a_pointer_word_aligned_from_the_image_start_passes(example, tmp_path):
    path = hex_of_binary(example, tmp_path)
    assert verify_file(path).relocations


# An init off an instruction boundary.


def test_verify_refuses_an_init_between_instructions_naming_the_08_line(example, tmp_path):
    path = hex_of_binary(example, tmp_path, init=0x10002)
    with pytest.raises(InitAlignmentError) as caught:
        verify_file(path)
    lines = path.read_text().splitlines()
    assert lines[caught.value.line - 1].startswith(":04000008")
    assert "4-byte instruction boundary (RV32IM), got 0x00010002" in str(caught.value)


def test_pack_refuses_an_init_symbol_that_is_not_code(example_builds, tmp_path, capsys):
    elf = example_builds["gain"].elf
    argv = ["pack", str(elf), "--init", "gain_descriptor", "-o", str(tmp_path / "x.hex")]
    message = refuse(argv, capsys)
    assert message.startswith(f"error: {elf}: expected the init symbol 'gain_descriptor' to be")
    assert "got a STT_OBJECT in .pbo_descriptor" in message


# An ELF linked without --emit-relocs.


def test_pack_refuses_an_elf_linked_without_emit_relocs(tmp_path, capsys):
    elf = build(EXAMPLES_DIR / "gain.c", tmp_path, emit_relocs=False).elf
    message = refuse(["pack", str(elf), "-o", str(tmp_path / "gain.hex")], capsys)
    assert message.startswith(f"error: {elf}: expected relocations for the absolute address of ")
    assert "(.pbo_descriptor), got no relocation sections: link with -Wl,--emit-relocs" in message
    assert not (tmp_path / "gain.hex").exists()


def test_verify_refuses_a_descriptor_method_without_its_07_record(tmp_path):
    unlinked = build(EXAMPLES_DIR / "gain.c", tmp_path, emit_relocs=False)
    path = hex_of_binary(unlinked, tmp_path, relocations=())
    with pytest.raises(MissingRelocationsError) as caught:
        verify_file(path)
    assert str(caught.value).startswith(
        f"{path}: expected an 07 record for the descriptor's method 'init' (the pointer word at "
    )
    assert "link it with -Wl,--emit-relocs" in str(caught.value)


def test_pack_refuses_code_that_holds_absolute_addresses(tmp_path, capsys):
    medlow = [f for f in COMPILE_FLAGS if f != "-mcmodel=medany"] + ["-mcmodel=medlow"]
    elf = build(EXAMPLES_DIR / "gain.c", tmp_path, compile_flags=medlow).elf
    message = refuse(["pack", str(elf), "-o", str(tmp_path / "gain.hex")], capsys)
    assert message.startswith(f"error: {elf}: expected relocations that a 07 record fixes or ")
    assert "got R_RISCV_HI20 against symbol 'gain_descriptor' at 0x00010000" in message
    assert "(in module_init, .text): an instruction holds part of an absolute address" in message
    assert message.endswith("compile with -mcmodel=medany, as module_sdk/build.py does")


# A map file from another build than the binary.


def test_pack_refuses_the_map_of_another_module(example_builds, tmp_path, capsys):
    gain, average = example_builds["gain"], example_builds["moving_average"]
    argv = ["pack", "--map", str(gain.map), "--bin", str(average.bin)]
    message = refuse([*argv, "-o", str(tmp_path / "x.hex")], capsys)
    assert message.startswith(f"error: {gain.map}: expected the descriptor's method ")
    assert "where the map names no function: pack the .bin and the .map that one build" in message


def test_pack_refuses_the_map_of_another_build_of_the_same_module(example_builds, tmp_path):
    other = build(EXAMPLES_DIR / "gain.c", tmp_path, optimise="-O2")
    with pytest.raises(MapMismatchError) as caught:
        image_from_map(other.bin, example_builds["gain"].map)
    assert caught.value.path == str(example_builds["gain"].map)
    assert "to come from the build that wrote this map" in str(caught.value)


def test_pack_refuses_a_binary_without_the_descriptor_where_the_map_has_it(example, tmp_path):
    linker_map = example.map.read_text()
    address = int(linker_map.split("\n.pbo_descriptor\n")[1].split()[0], 16)
    data = bytearray(example.bin.read_bytes())
    data[address - 0x10000 : address - 0x10000 + 4] = bytes(4)
    other = tmp_path / "other.bin"
    other.write_bytes(data)
    with pytest.raises(MapMismatchError, match="got 0x00000000 where its magic 0x314F4250 belongs"):
        image_from_map(other, example.map)


def test_the_map_route_packs_a_descriptor_of_another_abi_for_the_node_to_refuse(tmp_path):
    stranger = build(Path(__file__).parents[1] / "firmware_sim/guests/stranger.c", tmp_path)
    assert image_from_map(stranger.bin, stranger.map) == image_from_elf(stranger.elf)


# Compressed (RVC) code for a node that runs RV32IM.


@pytest.fixture(scope="module")
def rvc_build(tmp_path_factory: pytest.TempPathFactory) -> ModuleBuild:
    return build(EXAMPLES_DIR / "gain.c", tmp_path_factory.mktemp("rvc"), target=RV32IMC)


def test_pack_refuses_an_elf_with_compressed_code(rvc_build, tmp_path, capsys):
    message = refuse(["pack", str(rvc_build.elf), "-o", str(tmp_path / "gain.hex")], capsys)
    assert message.startswith(f"error: {rvc_build.elf}: expected RV32IM code, got e_flags 0x1")
    assert "compile with -march=rv32im" in message


def test_pack_refuses_compressed_code_from_the_map_route(rvc_build):
    with pytest.raises(CompressedCodeError, match="the 16-bit \\(compressed, RVC\\) instruction"):
        image_from_map(rvc_build.bin, rvc_build.map)


def test_verify_finds_compressed_code_reachable_from_init_in_a_hex_file(rvc_build, tmp_path):
    path = hex_of_binary(rvc_build, tmp_path)
    with pytest.raises(CompressedCodeError) as caught:
        verify_file(path)
    assert "on every path from init (0x00010000)" in str(caught.value)
    assert caught.value.path == str(path)


# A descriptor name longer than 15 characters.


def test_pack_and_verify_refuse_a_sixteen_character_name(tmp_path, capsys):
    source = tmp_path / "long.c"
    text = (EXAMPLES_DIR / "gain.c").read_text().replace('.name = "gain"', f'.name = "{SIXTEEN}"')
    source.write_text(text)
    long = build(source, tmp_path / "out", werror=False)
    with pytest.raises(NameLengthError, match=f"got '{SIXTEEN}' \\(16 characters, no NUL\\)"):
        image_from_elf(long.elf)
    message = refuse(["verify", str(hex_of_binary(long, tmp_path))], capsys)
    assert "expected a module name of at most 15 characters" in message


@settings(max_examples=200, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(changes=st.lists(st.tuples(st.integers(0, 0x37F), st.integers(0, 255)), max_size=40))
def test_the_code_walk_ends_on_any_code_with_a_pass_or_a_check_error(example_builds, changes):
    """Random bytes in gain's code and constants (its descriptor kept): every walk ends, and
    ends with a pass or a `ModuleCheckError`, never another exception."""
    data = bytearray(example_builds["gain"].bin.read_bytes())
    for offset, value in changes:
        data[offset] = value
    plain = ModuleImage("gain", 0x10000, bytes(data), (), 0x10000)
    found = find_descriptor(plain)
    assert found is not None
    slots = tuple(found[0] + abi.METHODS_OFFSET + 4 * index for index in range(9))
    image = ModuleImage("gain", 0x10000, bytes(data), slots, 0x10000)
    with contextlib.suppress(ModuleCheckError):
        check_module(image)
