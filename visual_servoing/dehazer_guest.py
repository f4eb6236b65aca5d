"""The Dehazer as guest code: guest/dehazer.c built with the SDK into a module image.

The C source is the module (ports, methods, evaluator and estimator, documented at its top);
this file only says where it is, how to build it, and the figures a node running it must allow
for. The image migrates like any other: ``image.write(path)`` gives the extended HEX file that
``hexmigrate send`` ships and `Node.load` installs.

A frame takes about 1.6 million guest instructions (benchmarks/dehazer.py prints the exact
count), far more than the node's default budget of 100,000 per method call: a node that runs the
Dehazer needs ``NodeConfig(budget=INSTRUCTION_BUDGET)``. At the default 100 MHz that is about
16 ms of virtual time per frame, within a 30 Hz period.
"""

from __future__ import annotations

from enum import IntEnum
from pathlib import Path

from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import ModuleBuild, build_module

SOURCE = Path(__file__).resolve().parent / "guest" / "dehazer.c"
NAME = "Dehazer"  # the descriptor's name, as the module database names it
INPUT_PORT = "raw"
OUTPUT_PORT = "image"
FRAME_SHAPE = (120, 160)  # rows, columns of both ports (ROWS, COLUMNS in the C source)
INSTRUCTION_BUDGET = 4_000_000  # per method call: over twice a frame's instructions


class DehazerFigure(IntEnum):
    """The functional values the evaluator and the estimator report, by index (grey levels)."""

    OUTPUT_CONTRAST = 0  # high - low after the stretch: 255 once restored
    INPUT_CONTRAST = 1  # high - low of the median image: small under fog
    NOISE_REMOVED = 2  # mean |raw - median| per pixel: large on a noisy camera


def build_dehazer(out_dir: Path) -> ModuleBuild:
    """Compile and link the Dehazer into `out_dir` (raises BuildError, e.g. without the cross
    compiler)."""
    return build_module(SOURCE, out_dir)


def dehazer_image(out_dir: Path) -> ModuleImage:
    """The Dehazer's module image, built into `out_dir`, ready to write as HEX or to load."""
    return image_from_elf(build_dehazer(out_dir).elf)
