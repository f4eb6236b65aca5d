"""The transaction-level model of the crossbar: the golden reference of the cocotb tests.

It knows no cycles, only order. A beat enters at an external input, follows the current
routing through the functionalities and leaves at one output: at once, or later (a 3x3 median
holds a row and a pixel of its frame, which the frame's ``last`` releases), so a beat sent in
takes out the beats the route emits with it, none to several.
A reconfiguration is an event between beats: ``load`` applies a partial bitstream exactly as a
wrapper would (same checks, same refusals, history cleared when the functionality's source
changes). Because the wrapper isolates its functionality until it has drained, a beat that
entered before the commit is already past the reconfigured slot; the model's order of events is
therefore the hardware's whenever the reconfigured slot is the first functionality of its route,
which is how the tests and the reconfiguration-port model use it.
"""

from __future__ import annotations

import operator
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from .bitstream import beats_to_word, decode_bytes, decode_frame, reconfiguration_cycles
from .errors import DataWidthError, RouteError
from .fabric import Fabric, Source, SourceKind
from .functions import Beat, FunctionState
from .routing import Configuration, SlotRoute


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

    def send(self, port: int, beat: Beat) -> tuple[int, list[Beat]]:
        """Send ``beat`` into external input ``port``; returns the output port its route ends
        at and the beats that leave there with it, in order: none while a functionality holds
        them, or several when one releases what it held."""
        self.fabric.check_slot(port)
        if beat.data >> self.fabric.data_w or beat.data < 0:
            raise DataWidthError(f"expected data below 2**{self.fabric.data_w}, got {beat.data}")
        source = Source(SourceKind.INPUT, port)
        beats = [beat]
        while True:
            taker = self.configuration.consumer(source)
            if taker is None:
                raise RouteError(f"expected a route from input {port}, got none past {source}")
            role, slot = taker
            if role == "output":
                return slot, beats
            step = self.states[slot].step
            beats = step(beats[0]) if len(beats) == 1 else [o for b in beats for o in step(b)]
            source = Source(SourceKind.FUNCTION, slot)

    def push(self, port: int, beat: Beat) -> tuple[int, Beat]:
        """Send ``beat`` into external input ``port`` on a route that gives one beat per beat
        (every functionality but the 3x3 median); returns (output port, beat out). RouteError,
        before the beat, for a route that may hold it (`send` takes any route)."""
        path = self.configuration.route_of(port)
        route = path.functions if path is not None else ()
        holding = [slot for slot in route if self.fabric.functions[slot].holds_beats]
        if holding:
            raise RouteError(
                f"expected a route from input {port} that gives a beat per beat, got "
                f"{self.fabric.functions[holding[0]]} in slot {holding[0]} (send takes it)"
            )
        out, (leaving,) = self.send(port, beat)
        return out, leaving

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Each external input's beats (the last one marked ``last``) through the routing, as
        the RTL takes them at once (`morphing_crossbar.verilated.rtl`); each output port's
        beats, in order, by port. An input routed to no output, or a port or beat
        `checked_inputs` refuses, is refused before any beat. Each input's beats cross its
        route's functionalities a whole frame at a time (`FunctionState.frame`: the beats one
        `send` at a time would give, since a functionality serves one route)."""
        inputs = checked_inputs(self.fabric, inputs)
        ends = self.configuration.require_routes(inputs)
        outputs: dict[int, list[int]] = {}
        for port, beats in inputs.items():
            path = self.configuration.route_of(port)
            assert path is not None  # require_routes refused an input routed nowhere
            if not beats:  # no frame: nothing leaves, and the output is not named (as the RTL)
                continue
            data = beats
            for slot in path.functions:  # each slot serves one route
                data = self.states[slot].frame(data)
            outputs.setdefault(ends[port], []).extend(data)
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
        """The wrapper's commit: the new route, and the functionality's history cleared when its
        source changes (a frame that only moves the output port keeps the stream's history)."""
        old = self.configuration.routes[slot]
        self.configuration = self.configuration.with_route(slot, route)
        if route.fsel != old.fsel:
            self.states[slot].reset()
        self.loads += 1
        return LoadResult(slot, route, reconfiguration_cycles(self.fabric))


def checked_inputs(fabric: Fabric, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
    """`inputs` with every port and beat a Python int, checked as both models' `stream` check
    them, so that they refuse alike: RouteError for a port that is no integer (a float, a
    string) or not a slot of `fabric`, DataWidthError for a beat that is no integer or does
    not fit the data width. An integer of any type passes as its value (`operator.index`: a
    NumPy integer, a bool), so no model truncates a float into a beat or computes with a NumPy
    scalar's wrapping arithmetic."""
    limit = 1 << fabric.data_w
    checked: dict[int, list[int]] = {}
    for key, beats in inputs.items():
        try:
            port = operator.index(key)
        except TypeError:
            raise RouteError(f"expected an input port as an integer, got {key!r}") from None
        fabric.check_slot(port)
        try:
            values = list(map(operator.index, beats))
        except TypeError:
            raise DataWidthError(
                f"expected input {port}'s data as integers below 2**{fabric.data_w}, got "
                f"{_not_an_integer(beats)!r}"
            ) from None
        if values and (min(values) < 0 or max(values) >= limit):
            wide = next(value for value in values if not 0 <= value < limit)
            raise DataWidthError(f"expected data below 2**{fabric.data_w}, got {wide}")
        checked[port] = values
    return checked


def _not_an_integer(beats: object) -> object:
    """What `checked_inputs` names: the first of `beats` that is no integer, or `beats` itself
    when it is not a sequence."""
    for beat in beats if isinstance(beats, Iterable) else ():
        try:
            operator.index(beat)
        except TypeError:
            return beat
    return beats
