"""Conformance: the same module on the same input gives the same output on every node
(`nodes.KINDS`): the Dehazer (visual_servoing/guest/dehazer.c) on a small frame, each node
started as a user starts it and driven with the real ``hexmigrate`` over a pty.

Neither node reads or sets a frame port over the protocol (READ: "only scalar ports are read";
SET: "a value sets only a scalar port"), so two test modules stand around the Dehazer:
``pattern`` writes one fixed test frame into its frame output, and ``digest`` reduces what the
Dehazer made of it to scalars the host reads at once: an FNV-1a hash of the output's bytes, their
sum, and the pixels that differ from the input. Equal hashes say the frames agree byte for
byte; the sum and the count say the output is not blank and not the input passed on.

The frame is small, ROWS x COLUMNS, and the Dehazer is built from its own source with only its
frame size changed (`dehazer_source`): the shipped 120x160 Dehazer's 1.6 M instructions a frame
are past the Python node's default budget of 100,000 a call (`nodes.py` starts both nodes as
they come), which the small frame stays well within, and the small frames keep the test fast.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from module_sdk.build import build_module
from tests.conformance.nodes import KINDS, MODE, BoardUnderTest
from tests.firmware_sim.host_side import hexmigrate
from visual_servoing.dehaze import dehaze
from visual_servoing.dehazer_guest import NAME, SOURCE

ROWS = 16
COLUMNS = 32
"""The test frame's size: 512 pixels (a 1% clip of 5 at each end of the stretch), on which the
Dehazer runs about 48,000 instructions a frame, half the Python node's default budget a call."""
PATTERN = """
#include "pbo_module.h"
static int32_t ok(struct pbo_context *ctx) { (void)ctx; return PBO_OK; }
/* Fog (levels 100 to 160, a gradient unlike along rows and columns) with salt and pepper. */
static int32_t cycle(struct pbo_context *ctx)
{
    uint8_t *frame = ctx->ports[0];
    for (uint32_t y = 0; y < ROWS; y++) {
        for (uint32_t x = 0; x < COLUMNS; x++) {
            const uint32_t h = (x * 2654435761u) ^ (y * 40503u + 12345u);
            const uint32_t fog = 100u + (3u * x + 2u * y) % 61u;
            frame[y * COLUMNS + x] = (uint8_t)(h % 29u == 0u ? 0u : h % 23u == 0u ? 255u : fog);
        }
    }
    return PBO_OK;
}
static const struct pbo_descriptor descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 1, .name = "pattern",
    .ports = {{"frame", PBO_PORT_OUT, PBO_FRAME, 1, ROWS, COLUMNS}},
    .init = ok, .on = ok, .cycle = cycle, .off = ok, .kill = ok, .error = ok, .clear = ok,
};
PBO_MODULE(descriptor)
"""
DIGEST = """
#include "pbo_module.h"
enum { RAW, IMAGE, HASH, SUM, CHANGED };
static int32_t ok(struct pbo_context *ctx) { (void)ctx; return PBO_OK; }
static int32_t cycle(struct pbo_context *ctx)
{
    const uint8_t *raw = ctx->ports[RAW];
    const uint8_t *image = ctx->ports[IMAGE];
    uint32_t hash = 2166136261u; /* FNV-1a, 32 bits */
    uint32_t sum = 0;
    uint32_t changed = 0;
    for (uint32_t i = 0; i < ROWS * COLUMNS; i++) {
        hash = (hash ^ image[i]) * 16777619u;
        sum += image[i];
        changed += image[i] != raw[i];
    }
    *(uint32_t *)ctx->ports[HASH] = hash;
    *(uint32_t *)ctx->ports[SUM] = sum;
    *(uint32_t *)ctx->ports[CHANGED] = changed;
    return PBO_OK;
}
static const struct pbo_descriptor descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 5, .name = "digest",
    .ports = {{"raw", PBO_PORT_IN, PBO_FRAME, 1, ROWS, COLUMNS},
              {"image", PBO_PORT_IN, PBO_FRAME, 1, ROWS, COLUMNS},
              {"hash", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
              {"sum", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
              {"changed", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = ok, .on = ok, .cycle = cycle, .off = ok, .kill = ok, .error = ok, .clear = ok,
};
PBO_MODULE(descriptor)
"""
WIRES = ("pattern.frame=Dehazer.raw", "pattern.frame=digest.raw", "Dehazer.image=digest.image")
DIGEST_PORTS = ("digest.hash", "digest.sum", "digest.changed")
SETTLE = 0.5
"""Seconds for the chain at 100 Hz to carry the frame through (a few periods are enough)."""


def dehazer_source() -> str:
    """dehazer.c with ROWS x COLUMNS frames and nothing else changed; it fails loudly if the
    source no longer fixes its frame size in two lines of its own."""
    source = SOURCE.read_text()
    for macro, size in (("ROWS", ROWS), ("COLUMNS", COLUMNS)):
        shipped = re.compile(rf"^#define {macro} \d+u$", re.MULTILINE)
        source, found = shipped.subn(f"#define {macro} {size}u", source)
        assert found == 1, f"{SOURCE}: expected one line '#define {macro} <N>u', found {found}"
    return source


@pytest.fixture(scope="module")
def frame_modules(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The Dehazer on ROWS x COLUMNS frames, the test frame's source and the digest, as module
    files by name."""
    folder = tmp_path_factory.mktemp("frame_modules")
    size = f"#define ROWS {ROWS}u\n#define COLUMNS {COLUMNS}u\n"
    sources = {NAME: dehazer_source(), "pattern": size + PATTERN, "digest": size + DIGEST}
    files = {}
    for name, text in sources.items():
        source = folder / f"{name.lower()}.c"
        source.write_text(text)
        files[name] = folder / f"{name}.hex"
        image_from_elf(build_module(source, folder / name).elf).write(files[name])
    return files


def input_frame() -> np.ndarray:
    """The frame ``pattern`` writes, computed as its C computes it (uint32 arithmetic)."""
    y, x = np.mgrid[0:ROWS, 0:COLUMNS].astype(np.uint64)
    h = ((x * 2654435761) & 0xFFFFFFFF) ^ ((y * 40503 + 12345) & 0xFFFFFFFF)
    fog = 100 + (3 * x + 2 * y) % 61
    return np.where(h % 29 == 0, 0, np.where(h % 23 == 0, 255, fog)).astype(np.uint8)


def signed(word: int) -> int:
    """A 32-bit word as READ gives an int32 port's value."""
    return word - (1 << 32) if word >= 1 << 31 else word


def digest(raw: np.ndarray, image: np.ndarray) -> dict[str, int]:
    """What ``digest`` reports for an output `image` of input `raw`, by port."""
    fnv = 2166136261
    for byte in image.tobytes():
        fnv = ((fnv ^ byte) * 16777619) & 0xFFFFFFFF
    return {
        "digest.hash": signed(fnv),
        "digest.sum": int(image.sum(dtype=np.int64)),
        "digest.changed": int((image != raw).sum()),
    }


def dehaze_on(kind: str, folder: Path, modules: dict[str, Path]) -> dict[str, int]:
    """Start a node of `kind`, send it `modules`, run the test frame through its Dehazer, and
    read the digest. The modules go with ``hexmigrate send``; the wiring, the starts and the
    reads over one link (test_control.py runs them through the command line)."""
    folder.mkdir()
    board = BoardUnderTest(kind, folder / "flash.img", folder / "node.log")
    try:
        for path in modules.values():
            hexmigrate("send", path, "--quiet", "--to", board.url, *MODE)
        with open_link(board.url) as link:
            node = NodeControl(Sender(link, MODE[1]))
            for wire in WIRES:
                node.connect(wire)
            for name in modules:
                node.start(name)
            time.sleep(SETTLE)
            values = dict(node.read(DIGEST_PORTS))  # the three at one moment
            states = {row.name: row.state for row in node.pbos()}
    finally:
        board.stop()
    assert states == dict.fromkeys(modules, "ON"), states
    return values


@pytest.mark.timeout(120)
def test_the_dehazer_gives_the_same_frame_on_every_node(tmp_path, frame_modules):
    """Both nodes' output frames are the same, byte for byte (the hash), and the frame the numpy
    reference (visual_servoing/dehaze.py) makes of the input: so both ran the Dehazer, not just
    the same wrong thing. The output is neither blank nor the input: the median took the salt
    and pepper out and the stretch spread the fog, which a node that ran nothing would not."""
    seen = {kind: dehaze_on(kind, tmp_path / kind, frame_modules) for kind in KINDS}
    raw = input_frame()
    assert seen["qemu"] == seen["python"], seen
    assert seen["python"] == digest(raw, dehaze(raw).image), seen
    assert seen["python"]["digest.sum"] > 0, seen
    assert seen["python"]["digest.changed"] > raw.size // 2, seen
