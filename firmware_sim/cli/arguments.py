"""The argument types of `firmware-sim` (argparse ``type=``), each with its range.

They build on `commandline.arguments`, so a number is refused the same way in every command
(NaN, infinities, out of range), and raise `argparse.ArgumentTypeError` with what was expected and
what came: a usage error, exit status 2.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

from commandline.arguments import (
    address,
    input_file,
    integer,
    output_file,
    output_file_ending,
    real,
)
from firmware_sim.core.memory_map import DEFAULT_FLASH_SIZE
from firmware_sim.core.node import RATE_MAX, RATE_MIN
from firmware_sim.core.port_values import Setting, setting
from firmware_sim.core.source_lines import source_lines
from hexmigrate.links.url import network_host
from pbort.trace import TraceFormatError, check_trace_name

MODULE_FILE_LIMIT = 4 * DEFAULT_FLASH_SIZE
"""Bytes of the largest module file read: an Intel HEX text is under 3 characters per byte of
image, so a file over four times the flash can hold no module that fits."""
SECONDS_MAX = 1_000_000.0
"""The longest run (--seconds), about eleven and a half days."""
CYCLES_MAX = 1_000_000_000
BIT_RATE_MIN, BIT_RATE_MAX = 300.0, 10_000_000.0
"""A wire's bit rate: from 300 baud to 10 Mbit/s."""
WINDOW_MAX = 256
"""Blocks in flight at most (64 KiB)."""
FABRIC_TEXT_MAX = 1024
"""Characters of an --fpga fabric at most: sixteen slots' functionalities fit many times over."""
WIDTH_MAX = 32
"""Bits of a fabric's sample at most (--fpga-width)."""

seconds = real(above=0, maximum=SECONDS_MAX, unit="s")
cycles = integer(1, CYCLES_MAX)
hertz = real(RATE_MIN, RATE_MAX, unit="Hz")
bit_rate = real(BIT_RATE_MIN, BIT_RATE_MAX, unit="bit/s")
window = integer(1, WINDOW_MAX)
fabric_width = integer(1, WIDTH_MAX)
module_file = input_file(MODULE_FILE_LIMIT)
flash_file = output_file
plot_file = output_file_ending(".png")


def module_elf(text: str) -> Path:
    """A module's ELF, decoded as the node decodes it for source lines (`source_lines`, cached,
    so the node does not decode it again): a file that is none (a HEX file, text, an ELF of
    another machine) is refused here, where the node would only log that it found no source
    lines in it."""
    path = module_file(text)
    try:
        source_lines(path.resolve(), path.stat().st_mtime)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return path


def fabric(text: str) -> str:
    """An FPGA fabric as the reconfiguration port reads it: a slot count, or a comma list of
    each slot's functionality. Only its size and characters are checked here; the port says
    what it cannot build (a usage error too, before the node listens)."""
    if not text.strip() or len(text) > FABRIC_TEXT_MAX or not text.isprintable():
        shown = repr(text) if len(text) <= 40 else f"{text[:37]!r}..."
        raise argparse.ArgumentTypeError(
            f"expected a slot count or a comma list of functionalities (median3x3:160,pass) "
            f"of at most {FABRIC_TEXT_MAX} printable characters, got {shown}"
        )
    return text


def bridge_host(text: str) -> str:
    """A host bridges may use: an IPv4 or IPv6 address or a host name (`network_host`)."""
    try:
        return network_host(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def trace_file(text: str) -> Path:
    """A trace to write: a .csv or .mcap file in an existing folder."""
    path = output_file(text)
    try:
        return check_trace_name(path)
    except TraceFormatError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


@dataclass(frozen=True)
class ModuleArgument:
    """``FILE.hex[@ADDR]``: a module file and, optionally, where in flash to load it."""

    path: Path
    address: int | None


def module(text: str) -> ModuleArgument:
    """``FILE.hex`` or ``FILE.hex@ADDR``: a regular file of bounded size, ADDR an address."""
    path, at, where = text.partition("@")
    if at and not where:
        raise argparse.ArgumentTypeError(
            f"expected FILE.hex or FILE.hex@ADDR with ADDR like 0x08001000, got {text!r}"
        )
    try:
        location = address(where) if at else None
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected FILE.hex or FILE.hex@ADDR with ADDR like 0x08001000, got {text!r}"
        ) from None
    return ModuleArgument(module_file(path), location)


def pbo_rate(text: str) -> tuple[str, float]:
    """``PBO=HZ``; PBO a name a kernel can register (printable, without blanks or '.')."""
    name, found, value = text.partition("=")
    try:
        if found and name and name.isprintable() and not any(c in name for c in " ."):
            return name, hertz(value)
    except argparse.ArgumentTypeError:
        pass
    raise argparse.ArgumentTypeError(
        f"expected PBO=HZ with HZ from {RATE_MIN:g} to {RATE_MAX:g}, got {text!r}"
    )


def port(text: str) -> str:
    """``PBO.port``."""
    pbo, dot, name = text.partition(".")
    if not (dot and pbo and name and "." not in name and "=" not in text):
        raise argparse.ArgumentTypeError(f"expected PBO.port, got {text!r}")
    return text


def wire(text: str) -> tuple[str, str]:
    """``OUT_PBO.port=IN_PBO.port``."""
    source, _, sink = text.partition("=")
    try:
        return port(source), port(sink)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected OUT_PBO.port=IN_PBO.port, got {text!r}"
        ) from None


def port_setting(text: str) -> Setting:
    """``PBO.port=VALUE``, VALUE a finite number."""
    try:
        return setting(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
