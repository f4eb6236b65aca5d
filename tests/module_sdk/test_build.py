"""The module SDK builds relocatable, reproducible module images that match the ABI header."""

import re
from pathlib import Path
from typing import NamedTuple

import pytest
from elftools.elf.constants import SH_FLAGS
from elftools.elf.elffile import ELFFile
from elftools.elf.relocation import RelocationSection

from hexmigrate.descriptor import (
    ABI_VERSION,
    MAGIC,
    MAX_PORTS,
    METHODS,
    METHODS_OFFSET,
    PORT_SIZE,
    SIZE,
    Descriptor,
    PortSpec,
)
from hexmigrate.errors import AbiMismatchError, DescriptorError
from hexmigrate.relocations import SUBTRACTIONS, refusal
from module_sdk import build
from module_sdk.build import ModuleBuild, build_examples, build_module
from module_sdk.errors import BuildError

LINK_BASE = 0x00010000
R_RISCV_32 = 1

# The descriptor layout is hexmigrate.descriptor's: decoding the images built from
# pbo_module.h with it checks that the C header and the Python decoder agree.


class Expected(NamedTuple):
    """What an example's source declares; prefix is the one its static method names share."""

    prefix: str
    state_size: int
    ports: tuple[PortSpec, ...]


EXPECTED = {
    "gain": Expected(
        prefix="gain",
        state_size=12,
        ports=(
            PortSpec("x", "in", "scalar", 4, 1, 1),
            PortSpec("y", "out", "scalar", 4, 1, 1),
            PortSpec("k", "const", "scalar", 4, 1, 1),
        ),
    ),
    "moving_average": Expected(
        prefix="ma",
        state_size=48,
        ports=(PortSpec("x", "in", "scalar", 4, 1, 1), PortSpec("y", "out", "scalar", 4, 1, 1)),
    ),
}

# A module with only two methods: the other seven descriptor slots are NULL.
MINIMAL_SOURCE = """\
#include "pbo_module.h"

static int32_t minimal_init(struct pbo_context *ctx)
{
    (void)ctx;
    return PBO_OK;
}

static int32_t minimal_cycle(struct pbo_context *ctx)
{
    *(int32_t *)ctx->ports[0] = (int32_t)pbo_sys_time_us();
    return PBO_OK;
}

static const struct pbo_descriptor minimal_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = 1,
    .name = "minimal",
    .ports = {{"t", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = minimal_init,
    .cycle = minimal_cycle,
};

PBO_MODULE(minimal_descriptor)
"""


# A module with a frame input and a vector output: shapes beyond 1x1.
SHAPES_SOURCE = """\
#include "pbo_module.h"

static int32_t shapes_cycle(struct pbo_context *ctx)
{
    const uint8_t *frame = ctx->ports[0];
    int16_t *histogram = ctx->ports[1];
    histogram[frame[0] >> 4]++;
    return PBO_OK;
}

static const struct pbo_descriptor shapes_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = 2,
    .name = "shapes",
    .ports = {
        {"image", PBO_PORT_IN, PBO_FRAME, sizeof(uint8_t), 48, 64},
        {"histogram", PBO_PORT_OUT, PBO_VECTOR, sizeof(int16_t), 1, 16},
    },
    .cycle = shapes_cycle,
};

PBO_MODULE(shapes_descriptor)
"""

# Offset of port 0's type (uint8), then element_size, rows and columns (uint16) in a descriptor.
PORT0_SHAPE_OFFSET = METHODS_OFFSET - MAX_PORTS * PORT_SIZE + 13


# A module that keeps a counter outside its context; DEFINITION is the variable's definition.
COUNTER_SOURCE = """\
#include "pbo_module.h"

DEFINITION

static int32_t counter_cycle(struct pbo_context *ctx)
{
    (void)ctx;
    calls++;
    return PBO_OK;
}

static const struct pbo_descriptor counter_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .name = "counter",
    .cycle = counter_cycle,
};

PBO_MODULE(counter_descriptor)
"""


@pytest.fixture(scope="module")
def examples(tmp_path_factory: pytest.TempPathFactory) -> list[ModuleBuild]:
    return build_examples(tmp_path_factory.mktemp("examples"))


@pytest.fixture(scope="module")
def minimal(tmp_path_factory: pytest.TempPathFactory) -> ModuleBuild:
    source_dir = tmp_path_factory.mktemp("minimal_src")
    source = source_dir / "minimal.c"
    source.write_text(MINIMAL_SOURCE)
    return build_module(source, tmp_path_factory.mktemp("minimal_out"))


def text_input_sections(map_text: str) -> dict[str, int]:
    """Start address of each `.text.<function>` input section listed in a GNU ld map file."""
    pattern = re.compile(r"^ (\.text\.\S+)\s+0x([0-9a-f]+)\s+0x[0-9a-f]+ \S+$", re.MULTILINE)
    return {name: int(address, 16) for name, address in pattern.findall(map_text)}


def check_image(module: ModuleBuild) -> Descriptor:
    """Check the ELF of one module against the loader's assumptions; return its descriptor."""
    with module.elf.open("rb") as stream:
        elf = ELFFile(stream)
        symbols = {
            symbol.name: symbol for symbol in elf.get_section_by_name(".symtab").iter_symbols()
        }
        function_starts = {
            symbol["st_value"]
            for symbol in symbols.values()
            if symbol["st_info"]["type"] == "STT_FUNC"
        }

        loads = [segment for segment in elf.iter_segments() if segment["p_type"] == "PT_LOAD"]
        assert len(loads) == 1
        (load,) = loads
        image = load.data()
        assert load["p_vaddr"] == LINK_BASE == symbols["__module_start"]["st_value"]
        assert load["p_filesz"] == load["p_memsz"] == len(image)
        assert symbols["__module_end"]["st_value"] == LINK_BASE + len(image)
        assert image == module.bin.read_bytes()
        assert elf.header["e_entry"] == symbols["module_init"]["st_value"] == LINK_BASE

        descriptor_section = elf.get_section_by_name(".pbo_descriptor")
        start = descriptor_section["sh_addr"]
        assert descriptor_section["sh_size"] == SIZE
        data = image[start - LINK_BASE : start - LINK_BASE + SIZE]
        assert data.startswith(MAGIC.to_bytes(4, "little"))
        descriptor = Descriptor.decode(data)  # rejects a wrong magic, ABI version or port count
        unused_ports = data[
            METHODS_OFFSET - (MAX_PORTS - len(descriptor.ports)) * PORT_SIZE : METHODS_OFFSET
        ]
        assert unused_ports == bytes(len(unused_ports))

        pointer_words: list[tuple[int, int]] = []
        for section in elf.iter_sections():
            if not isinstance(section, RelocationSection):
                continue
            target = elf.get_section(section["sh_info"])
            if not target["sh_flags"] & SH_FLAGS.SHF_ALLOC:
                continue
            symtab = elf.get_section(section["sh_link"])
            for relocation in section.iter_relocations():
                kind = relocation["r_info_type"]
                paired = any(
                    other["r_offset"] == relocation["r_offset"]
                    and other["r_info_type"] in SUBTRACTIONS
                    for other in section.iter_relocations()
                )
                assert refusal(kind, paired) is None, (target.name, relocation)
                if kind != R_RISCV_32:
                    continue
                symbol = symtab.get_symbol(relocation["r_info_sym"])
                value = symbol["st_value"] + relocation["r_addend"]
                pointer_words.append((relocation["r_offset"], value))

    text_starts = set(text_input_sections(module.map.read_text()).values())
    slot_base = start + METHODS_OFFSET
    expected_words = [
        (slot_base + 4 * index, address)
        for index, address in enumerate(descriptor.methods.values())
        if address != 0
    ]
    assert sorted(pointer_words) == expected_words
    for _, value in pointer_words:
        assert value in function_starts
        assert value in text_starts
    return descriptor


def test_builds_are_byte_identical_across_output_directories(tmp_path: Path) -> None:
    first = build_examples(tmp_path / "one")
    second = build_examples(tmp_path / "deeper" / "two")
    assert [module.name for module in first] == ["gain", "moving_average"]
    for a, b in zip(first, second, strict=True):
        for suffix in (".o", ".elf", ".map", ".bin", ".objcopy.hex"):
            name = f"{a.name}{suffix}"
            assert (a.elf.parent / name).read_bytes() == (b.elf.parent / name).read_bytes(), name


def test_example_images_relocate_only_descriptor_method_pointers(
    examples: list[ModuleBuild],
) -> None:
    for module in examples:
        descriptor = check_image(module)
        assert all(address != 0 for address in descriptor.methods.values()), module.name


def test_null_methods_have_no_relocation(minimal: ModuleBuild) -> None:
    descriptor = check_image(minimal)
    present = [name for name, address in descriptor.methods.items() if address]
    assert present == ["init", "cycle"]


def test_frame_and_vector_ports_keep_their_shape(tmp_path: Path) -> None:
    source = tmp_path / "shapes.c"
    source.write_text(SHAPES_SOURCE)
    descriptor = check_image(build_module(source, tmp_path / "out"))
    assert descriptor.ports == (
        PortSpec("image", "in", "frame", 1, 48, 64),
        PortSpec("histogram", "out", "vector", 2, 1, 16),
    )
    assert [port.size_bytes for port in descriptor.ports] == [48 * 64, 32]


def descriptor_bytes(module: ModuleBuild) -> bytes:
    """The descriptor as it sits in the module's image."""
    with module.elf.open("rb") as stream:
        start = ELFFile(stream).get_section_by_name(".pbo_descriptor")["sh_addr"] - LINK_BASE
    return module.bin.read_bytes()[start : start + SIZE]


@pytest.mark.parametrize(
    ("kind", "shape", "message"),
    [
        (0, (3, 1, 1), "expected an element size in (1, 2, 4), got 3"),
        (2, (4, 0, 1), "expected at least 1 row and 1 column, got 0x1"),
        (0, (4, 1, 2), "expected a scalar of 1x1, got 1x2"),
        (1, (4, 2, 4), "expected a vector of 1xN (one row), got 2x4"),
    ],
)
def test_port_shapes_outside_the_abi_are_refused(
    minimal: ModuleBuild, kind: int, shape: tuple[int, int, int], message: str
) -> None:
    data = bytearray(descriptor_bytes(minimal))
    data[PORT0_SHAPE_OFFSET : PORT0_SHAPE_OFFSET + 7] = bytes([kind]) + b"".join(
        value.to_bytes(2, "little") for value in shape
    )
    with pytest.raises(DescriptorError, match=re.escape(f"port 0 ('t'): {message}")):
        Descriptor.decode(bytes(data))


def test_wrong_magic_or_version_is_an_abi_mismatch(minimal: ModuleBuild) -> None:
    data = descriptor_bytes(minimal)
    with pytest.raises(AbiMismatchError, match="expected descriptor magic 0x314F4250"):
        Descriptor.decode(b"PBO2" + data[4:])
    with pytest.raises(AbiMismatchError, match="expected ABI version 1, got 2"):
        Descriptor.decode(data[:4] + (2).to_bytes(2, "little") + data[6:])


def test_methods_are_local_functions_in_their_own_sections(examples: list[ModuleBuild]) -> None:
    for module in examples:
        sections = text_input_sections(module.map.read_text())
        assert min(sections.values()) == sections[".text.module_init"] == LINK_BASE
        with module.elf.open("rb") as stream:
            symtab = ELFFile(stream).get_section_by_name(".symtab")
            global_functions = {
                symbol.name
                for symbol in symtab.iter_symbols()
                if symbol["st_info"]["type"] == "STT_FUNC"
                and symbol["st_info"]["bind"] == "STB_GLOBAL"
            }
        assert global_functions == {"module_init"}
        prefix = EXPECTED[module.name].prefix
        for method in METHODS:
            assert f".text.{prefix}_{method}" in sections, (module.name, method)


def test_example_descriptors_match_their_sources(examples: list[ModuleBuild]) -> None:
    for module in examples:
        descriptor = check_image(module)
        expected = EXPECTED[module.name]
        assert descriptor.abi_version == ABI_VERSION == 1
        assert descriptor.name == module.name
        assert descriptor.state_size == expected.state_size
        assert len(descriptor.ports) == len(expected.ports)
        assert descriptor.ports == expected.ports


def assertion_text() -> str:
    """The message of the linker script's ASSERT against static variables."""
    script = build.LINKER_SCRIPT.read_text()
    match = re.search(r'ASSERT\(.*?"([^"]+)"\)', script, re.DOTALL)
    assert match is not None
    return match.group(1)


@pytest.mark.parametrize(
    "definition",
    [
        "static int32_t calls;",
        "static int32_t calls = 5;",
        "int32_t calls;",
        "static __thread int32_t calls;",
    ],
    ids=["bss", "data", "global", "thread_local"],
)
def test_static_variables_are_rejected_by_the_linker_script(
    tmp_path: Path, definition: str
) -> None:
    source = tmp_path / "counter.c"
    source.write_text(COUNTER_SOURCE.replace("DEFINITION", definition))
    with pytest.raises(BuildError) as caught:
        build_module(source, tmp_path / "out")
    assert "ctx->state" in assertion_text()
    assert "failed linking counter.elf" in str(caught.value)
    assert assertion_text() in str(caught.value)


def test_compiler_errors_carry_the_compiler_message(tmp_path: Path) -> None:
    source = tmp_path / "broken.c"
    source.write_text('#include "pbo_module.h"\nint32_t broken(void) { return 1 }\n')
    with pytest.raises(BuildError) as caught:
        build_module(source, tmp_path / "out")
    message = str(caught.value)
    assert "riscv64-unknown-elf-gcc failed compiling broken.c" in message
    assert "broken.c:2:" in message
    assert "expected ';'" in message


def test_missing_compiler_names_the_debian_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(BuildError, match="apt-get install gcc-riscv64-unknown-elf"):
        build_module(build.EXAMPLES_DIR / "gain.c", tmp_path / "out")


def test_missing_source_is_a_build_error(tmp_path: Path) -> None:
    with pytest.raises(BuildError, match="does not exist"):
        build_module(tmp_path / "absent.c", tmp_path / "out")


def test_unusable_output_directory_is_a_build_error(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(BuildError, match="cannot create output directory"):
        build_module(build.EXAMPLES_DIR / "gain.c", blocker / "out")


def test_cli_prints_one_line_per_module(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert build.main(["--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["gain", "moving_average"]
    assert f"elf={tmp_path.resolve() / 'gain.elf'}" in lines[0]
    # the module file is what hexmigrate pack writes, not objcopy's HEX (issue 26, point 10)
    assert (
        f"the module file: hexmigrate pack {tmp_path.resolve() / 'gain.elf'} -o gain.hex"
        in (lines[0])
    )
    assert "hex=" not in lines[0] and "gain.objcopy.hex is objcopy's plain Intel HEX" in lines[0]


def test_cli_reports_errors_without_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = tmp_path / "broken.c"
    source.write_text("int broken(void) { return 1 }\n")
    assert build.main(["--out", str(tmp_path / "out"), str(source)]) == 1
    captured = capsys.readouterr()
    assert captured.err.startswith("error: riscv64-unknown-elf-gcc failed compiling broken.c")
    assert "Traceback" not in captured.err
    assert build.main(["--debug", "--out", str(tmp_path / "out"), str(source)]) == 1
    debugged = capsys.readouterr().err
    assert debugged.startswith("Traceback") and "BuildError" in debugged
    assert debugged.splitlines()[-1] == captured.err.splitlines()[-1]
