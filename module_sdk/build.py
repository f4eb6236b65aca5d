"""Build migrating modules: C source -> object, ELF, map file, raw binary and plain Intel HEX.

The flow is the reproducible one from the toolchain notes: compile with ``-c``, then link in a
second call (a one-step build puts a random temporary object name into the map file). Every tool
runs in the output directory with relative file names, and ``-ffile-prefix-map`` strips the
source directory from the object's file symbol, so the outputs are byte-identical whatever the
output directory and wherever the checkout lives.

Usage: ``python -m module_sdk.build [--gdb] --out DIR [SOURCE.c ...]`` (default: all examples;
``--gdb`` builds for gdb: -Og -g3, the source copied beside the ELF).
"""

import argparse
import shutil
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from commandline import command_parser, entry_point, run
from commandline.arguments import input_file
from module_sdk.errors import BuildError, SdkError

SDK_DIR = Path(__file__).resolve().parent
EXAMPLES_DIR = SDK_DIR / "examples"
LINKER_SCRIPT = SDK_DIR / "module.ld"

GCC = "riscv64-unknown-elf-gcc"
OBJCOPY = "riscv64-unknown-elf-objcopy"
# The Debian package that provides each tool (objcopy comes with the compiler's binutils).
_PACKAGES = {GCC: "gcc-riscv64-unknown-elf", OBJCOPY: "binutils-riscv64-unknown-elf"}

LIBGCC = "-lgcc"
"""The compiler's support library for the rv32im/ilp32 multilib (the linker picks it from TARGET):
soft float, 64-bit division and the like. Debian's is built position-independent (PC-relative
references only, tables reached with auipc), so a module that links it still loads anywhere;
`hexmigrate pack` refuses any relocation that would pin a module to its link base."""

# Both steps must agree on the ISA and ABI: the linker refuses to mix them.
TARGET = ["-march=rv32im", "-mabi=ilp32"]
COMPILE_FLAGS = [
    *TARGET,
    "-mcmodel=medany",  # PC-relative code: only descriptor words need fixing when the image moves
    "-Os",
    "-g",  # DWARF for fault messages and gdb: debug sections are not loaded, the image is unchanged
    "-nostdlib",
    "-ffreestanding",
    "-ffunction-sections",  # one .text.<function> input section each, named in the map file
    "-fno-asynchronous-unwind-tables",
    "-fno-unwind-tables",
    "-fno-common",  # tentative definitions become .bss, which the linker script rejects
    "-Wall",
    "-Wextra",
    "-Werror",
]
OPTIMIZED = ("-Os", "-g")
"""What COMPILE_FLAGS build for by default: small code (what flash and the link carry), but -Os
keeps few locals alive for gdb."""
DEBUG = ("-Og", "-g3")
"""What ``--gdb`` builds for instead: code gdb steps through with its locals (and the macros),
a larger image."""


@dataclass(frozen=True)
class ModuleBuild:
    """The files one module build produced, all in the same output directory."""

    name: str
    elf: Path
    map: Path
    bin: Path
    objcopy_hex: Path


def _tool(name: str) -> str:
    """Find a cross tool on PATH, or say which Debian package installs it."""
    path = shutil.which(name)
    if path is None:
        raise BuildError(
            f"{name} not found on PATH: install it with "
            f"`apt-get install {_PACKAGES[name]}` (as root, after `apt-get update`)"
        )
    return path


def _run(command: list[str], step: str, cwd: Path) -> None:
    """Run one tool in the output directory; a failure carries the tool's own diagnostics."""
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        output = (result.stderr + result.stdout).strip()
        raise BuildError(
            f"{Path(command[0]).name} failed {step} in {cwd} "
            f"(exit status {result.returncode}):\n{output}"
        )


def build_module(source: Path, out_dir: Path, debug: bool = False) -> ModuleBuild:
    """Compile and link one module source into ``out_dir``, named after the source's stem;
    `debug` builds for gdb (`DEBUG`: -Og -g3) rather than for size (`OPTIMIZED`), and copies
    the source beside the ELF, where a node's ``gdb: directory`` line points gdb.

    Produces NAME.o, NAME.elf (with --emit-relocs, so every absolute pointer word is listed as an
    R_RISCV_32 relocation), NAME.map, NAME.bin (the image bytes from the link base) and
    NAME.objcopy.hex (objcopy's plain Intel HEX, a reference for the extended HEX writer).
    """
    source = source.resolve()
    if not source.is_file():
        raise BuildError(f"module source {source} does not exist")
    gcc = _tool(GCC)
    objcopy = _tool(OBJCOPY)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise BuildError(f"cannot create output directory {out_dir}: {error.strerror}") from error
    out_dir = out_dir.resolve()

    name = source.stem
    obj, elf, map_file = f"{name}.o", f"{name}.elf", f"{name}.map"
    binary, hex_file = f"{name}.bin", f"{name}.objcopy.hex"
    # The file symbol and the DWARF would otherwise hold the source's, the SDK's and the output
    # directory's absolute paths.
    prefixes = [
        f"-ffile-prefix-map={source.parent}/=",
        f"-ffile-prefix-map={SDK_DIR}/=sdk/",
        f"-ffile-prefix-map={out_dir}=.",
    ]
    flags = [*(f for f in COMPILE_FLAGS if f not in OPTIMIZED), *DEBUG] if debug else COMPILE_FLAGS
    compile_command = [gcc, *flags, f"-I{SDK_DIR}", *prefixes, "-c", str(source)]
    _run([*compile_command, "-o", obj], f"compiling {source.name}", out_dir)
    link_flags = ["-nostdlib", "-T", str(LINKER_SCRIPT), "-Wl,--emit-relocs"]
    # libgcc after the object: soft float, 64-bit division (LIBGCC says why it may move).
    link_outputs = [f"-Wl,-Map={map_file}", "-Wl,--build-id=none", obj, LIBGCC, "-o", elf]
    _run([gcc, *TARGET, *link_flags, *link_outputs], f"linking {elf}", out_dir)
    _run([objcopy, "-O", "binary", elf, binary], f"writing {binary}", out_dir)
    _run([objcopy, "-O", "ihex", elf, hex_file], f"writing {hex_file}", out_dir)
    if debug and source.parent != out_dir:
        shutil.copyfile(source, out_dir / source.name)  # the DWARF names it relative: ./NAME.c
    return ModuleBuild(
        name=name,
        elf=out_dir / elf,
        map=out_dir / map_file,
        bin=out_dir / binary,
        objcopy_hex=out_dir / hex_file,
    )


def example_sources() -> list[Path]:
    """The example modules shipped with the SDK, in a stable (sorted) order."""
    return sorted(EXAMPLES_DIR.glob("*.c"))


def build_examples(out_dir: Path) -> list[ModuleBuild]:
    """Build every example module into ``out_dir``."""
    return [build_module(source, out_dir) for source in example_sources()]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m module_sdk.build``."""
    parser = command_parser(
        "python -m module_sdk.build",
        "Build migrating modules (C for RV32IM) into ELF, map, binary and Intel HEX.",
    )
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument(
        "--gdb",
        action="store_true",
        help="build for gdb: -Og -g3 (locals and macros; a larger image), the source copied "
        "beside the ELF (--debug is the traceback's, as in every command)",
    )
    parser.add_argument(
        "sources",
        nargs="*",
        type=input_file(),
        metavar="SOURCE.c",
        help="default: the SDK's examples",
    )
    parser.set_defaults(func=build_command)
    return parser


def build_command(args: argparse.Namespace) -> None:
    """Build each source (the examples by default) and print one line per module."""
    for source in args.sources or example_sources():
        built = build_module(source, args.out, args.gdb)
        print(
            f"{built.name}: elf={built.elf} map={built.map} bin={built.bin} "
            f"(the module file: hexmigrate pack {built.elf} -o {built.name}.hex; "
            f"{built.objcopy_hex.name} is objcopy's plain Intel HEX, not a module file)"
        )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    return run(build_parser(), SdkError, argv)


if __name__ == "__main__":
    with entry_point():
        sys.exit(main())
