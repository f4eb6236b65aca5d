"""The transaction-level model of the crossbar: the golden reference of the cocotb tests.

It knows no cycles, only order. A beat enters at an external input, follows the current
routing through the functionalities (each keeps its FIR history) and leaves at one output.
A reconfiguration is an event between beats: ``load`` applies a partial bitstream exactly as a
wrapper would (same checks, same refusals, history cleared on commit). Because the wrapper
isolates its functionality until it has drained, a beat that entered before the commit is
already past the reconfigured slot; the model's order of events is therefore the hardware's
whenever the reconfigured slot is the first functionality of its route, which is how the
tests and the reconfiguration-port model use it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from .bitstream import beats_to_word, decode_bytes, decode_frame, reconfiguration_cycles
from .errors import DataWidthError, RouteError
from .fabric import Fabric, Source, SourceKind
from .functions import FunctionState
from .routing import Configuration, SlotRoute


@dataclass(frozen=True)
class Beat:
    """One stream transfer."""

    data: int
    last: bool = False


@dataclass(frozen=True)
class LoadResult:
    """What loading a partial bitstream did: the slot, its new route, the cycles it took."""

    slot: int
    route: SlotRoute
    cycles: int


class CrossbarModel:
    """Routing plus functionality state of one fabric."""

    def __init__(self, fabric: Fabric, configuration: Configuration | None = None) -> None:
        self.fabric = fabric
        self.configuration = configuration or Configuration.reset(fabric)
        self.states = [FunctionState(f, fabric.data_w) for f in fabric.functions]
        self.loads = 0

    def push(self, port: int, beat: Beat) -> tuple[int, Beat]:
        """Send ``beat`` into external input ``port``; returns (output port, beat out)."""
        self.fabric.check_slot(port)
        if beat.data >> self.fabric.data_w or beat.data < 0:
            raise DataWidthError(f"expected data below 2**{self.fabric.data_w}, got {beat.data}")
        source = Source(SourceKind.INPUT, port)
        data = beat.data
        while True:
            taker = self.configuration.consumer(source)
            if taker is None:
                raise RouteError(f"expected a route from input {port}, got none past {source}")
            role, slot = taker
            if role == "output":
                return slot, Beat(data, beat.last)
            data = self.states[slot].step(data)
            source = Source(SourceKind.FUNCTION, slot)

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Each external input's beats (the last one marked ``last``) through the routing, as
        the RTL takes them at once (`morphing_crossbar.verilated.rtl`); each output port's
        beats, in order, by port. An input routed to no output is refused before any beat."""
        self.configuration.require_routes(inputs)
        outputs: dict[int, list[int]] = {}
        for port, beats in inputs.items():
            for index, data in enumerate(beats):
                out, beat = self.push(port, Beat(data, index == len(beats) - 1))
                outputs.setdefault(out, []).append(beat.data)
        return outputs

    def load(self, slot: int, frame: bytes) -> LoadResult:
        """Apply a partial bitstream held as bytes to ``slot`` (raises what the wrapper refuses)."""
        return self._commit(slot, decode_bytes(self.fabric, slot, frame))

    def load_beats(self, slot: int, beats: list[int]) -> LoadResult:
        """Apply a partial bitstream as the configuration port beats that carried it."""
        cfg_w = self.fabric.cfg_w
        route = decode_frame(self.fabric, slot, beats_to_word(beats, cfg_w), len(beats) * cfg_w)
        return self._commit(slot, route)

    def _commit(self, slot: int, route: SlotRoute) -> LoadResult:
        self.configuration = self.configuration.with_route(slot, route)
        self.states[slot].reset()
        self.loads += 1
        return LoadResult(slot, route, reconfiguration_cycles(self.fabric))
