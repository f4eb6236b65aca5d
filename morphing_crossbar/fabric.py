"""The fabric's parameters and the sources each wrapper can select.

A wrapper has two selectors (functionality input, output port), each a 4-bit field of the frame.
For slot i: 0 none, 1 its own external input, 2 the ring (functionality output of slot i-1 mod N),
3+k the local crossbar (functionality output of slot k of i's cluster of ``local`` slots), and
3+local+k the local crossbar's external inputs (the input of slot k of i's cluster): the Morphing
Bus plugs a board into the cluster through them, so a board on any port of the cluster reaches
the same internal modules (`morphing_crossbar.morphing_bus`).
``verilog_parameters`` is the one place that turns a Fabric into the RTL's parameters.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

from .errors import FabricParameterError, RouteError
from .functions import Function, Kind, check_data_width, default_library

SEL_W = 4
"""Selector field width in the frame (sources per slot <= 16)."""

FRAME_BITS = 16 + 2 * SEL_W
"""Bits of a partial bitstream: magic, slot, two selectors, CRC-8."""

NONE_SEL = 0
INPUT_SEL = 1
RING_SEL = 2
LOCAL_SEL = 3
MAX_LOCAL = ((1 << SEL_W) - LOCAL_SEL) // 2
"""The largest cluster whose functionality outputs and external inputs all fit a selector."""


class SourceKind(Enum):
    """Where a stream comes from."""

    NONE = "none"
    INPUT = "input"
    FUNCTION = "function"


class Source(NamedTuple):
    """A stream in the fabric: an external input or a functionality output of ``slot``."""

    kind: SourceKind
    slot: int = -1

    def __str__(self) -> str:
        if self.kind is SourceKind.NONE:
            return "none"
        return f"{'in' if self.kind is SourceKind.INPUT else 'fn'}{self.slot}"


NO_SOURCE = Source(SourceKind.NONE)


@dataclass(frozen=True)
class Fabric:
    """Parameters of one morphing crossbar build.

    ``n`` slots (2..16), ``data_w`` payload bits, ``cfg_w`` configuration port bits a beat (it
    must divide the 24-bit frame), ``local`` slots per cluster (default min(n, 4); it must divide
    n and be at most ``MAX_LOCAL``), ``functions`` the functionality of each slot (default
    ``default_library``).
    """

    n: int
    data_w: int = 8
    cfg_w: int = 1
    local: int = 0
    functions: tuple[Function, ...] = ()

    def __post_init__(self) -> None:
        if not 2 <= self.n <= 16:
            raise FabricParameterError(f"expected 2..16 slots, got n={self.n}")
        if not 1 <= self.data_w <= 32:
            raise FabricParameterError(f"expected a data width of 1..32 bits, got {self.data_w}")
        if not self.local:
            object.__setattr__(self, "local", min(self.n, 4))
        if not 1 <= self.local <= MAX_LOCAL or self.n % self.local:
            raise FabricParameterError(
                f"expected a cluster size dividing n={self.n} and at most {MAX_LOCAL}, "
                f"got {self.local}"
            )
        if self.cfg_w < 1 or FRAME_BITS % self.cfg_w:
            raise FabricParameterError(
                f"expected a configuration width dividing the {FRAME_BITS}-bit frame, "
                f"got {self.cfg_w}"
            )
        if not self.functions:
            object.__setattr__(self, "functions", default_library(self.n, self.data_w))
        if len(self.functions) != self.n:
            raise FabricParameterError(
                f"expected {self.n} functionalities, one per slot, got {len(self.functions)}"
            )
        check_data_width(self.functions, self.data_w)

    @property
    def nsrc(self) -> int:
        """Sources each selector can choose, ``none`` included."""
        return self.input_selector_base + self.local

    @property
    def input_selector_base(self) -> int:
        """The selector value of the external input of slot 0 of a cluster (the local
        crossbar's inputs follow its functionality outputs)."""
        return LOCAL_SEL + self.local

    @property
    def frame_beats(self) -> int:
        """Configuration port beats of one partial bitstream."""
        return FRAME_BITS // self.cfg_w

    def cluster(self, slot: int) -> int:
        """The first slot of ``slot``'s local cluster."""
        return slot // self.local * self.local

    def self_selector(self, slot: int) -> int:
        """The selector value of ``slot``'s own functionality output (its local entry)."""
        return LOCAL_SEL + slot - self.cluster(slot)

    def source(self, slot: int, sel: int) -> Source:
        """What selector value ``sel`` means in ``slot``'s wrapper."""
        self.check_slot(slot)
        if sel == NONE_SEL:
            return NO_SOURCE
        if sel == INPUT_SEL:
            return Source(SourceKind.INPUT, slot)
        if sel == RING_SEL:
            return Source(SourceKind.FUNCTION, (slot - 1) % self.n)
        if LOCAL_SEL <= sel < self.input_selector_base:
            return Source(SourceKind.FUNCTION, self.cluster(slot) + sel - LOCAL_SEL)
        if self.input_selector_base <= sel < self.nsrc:
            return Source(SourceKind.INPUT, self.cluster(slot) + sel - self.input_selector_base)
        raise RouteError(f"expected a selector below {self.nsrc} for slot {slot}, got {sel}")

    def selector(self, slot: int, source: Source) -> int:
        """The selector value that makes ``slot`` read ``source``: its own input before the
        local crossbar's, the ring before the local crossbar (one value per source, so that two
        equal sources in a wrapper are two equal selectors)."""
        self.check_slot(slot)
        if source.kind is SourceKind.NONE:
            return NONE_SEL
        same_cluster = self.cluster(source.slot) == self.cluster(slot)
        if source.kind is SourceKind.INPUT:
            if source.slot == slot:
                return INPUT_SEL
            if same_cluster:
                return self.input_selector_base + source.slot - self.cluster(slot)
            raise RouteError(
                f"expected {source} to be slot {slot}'s own input or in its cluster "
                f"({self._describe_cluster(slot)}), got neither"
            )
        if source.slot == (slot - 1) % self.n:
            return RING_SEL
        if same_cluster:
            return LOCAL_SEL + source.slot - self.cluster(slot)
        raise RouteError(
            f"expected {source} to be slot {slot}'s ring neighbour or in its cluster "
            f"({self._describe_cluster(slot)}), got neither"
        )

    def _describe_cluster(self, slot: int) -> str:
        first = self.cluster(slot)
        return f"slots {first}..{first + self.local - 1}"

    def check_slot(self, slot: int) -> None:
        """Refuse a slot index outside the fabric."""
        if not 0 <= slot < self.n:
            raise RouteError(f"expected a slot in 0..{self.n - 1}, got {slot}")


def verilog_parameters(fabric: Fabric, design: str = "morphing_crossbar") -> dict[str, object]:
    """The parameters of ``design`` for ``fabric``, as sized literals: ``morphing_crossbar`` or a
    reference design (``full_crossbar``, ``shared_bus``), which has no cluster size ``LOCAL``."""
    kinds = sum(int(f.kind) << (4 * i) for i, f in enumerate(fabric.functions))
    p0 = sum(f.p0 << (16 * i) for i, f in enumerate(fabric.functions))
    p1 = sum(f.p1 << (16 * i) for i, f in enumerate(fabric.functions))
    n = fabric.n
    local = {"LOCAL": fabric.local} if design == "morphing_crossbar" else {}
    return {
        "N": n,
        "DATA_W": fabric.data_w,
        "CFG_W": fabric.cfg_w,
        **local,
        "FUNC_KIND": f"{4 * n}'h{kinds:0{n}x}",
        "FUNC_P0": f"{16 * n}'h{p0:0{4 * n}x}",
        "FUNC_P1": f"{16 * n}'h{p1:0{4 * n}x}",
    }


def fabric_to_json(fabric: Fabric) -> str:
    """``fabric`` as JSON, to hand it to a cocotb test module through the environment."""
    functions = [[int(f.kind), f.p0, f.p1] for f in fabric.functions]
    fields = {"n": fabric.n, "data_w": fabric.data_w, "cfg_w": fabric.cfg_w}
    return json.dumps({**fields, "local": fabric.local, "functions": functions})


def fabric_from_json(text: str) -> Fabric:
    """The inverse of ``fabric_to_json``."""
    raw = json.loads(text)
    functions = tuple(Function(Kind(k), p0, p1) for k, p0, p1 in raw["functions"])
    return Fabric(raw["n"], raw["data_w"], raw["cfg_w"], raw["local"], functions)
