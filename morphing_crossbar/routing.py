"""Routes: what each wrapper selects, and the checks a whole-fabric configuration must pass.

A wrapper checks its own frame (range, one selector value twice, feeding itself); it cannot see
the other wrappers, so the fabric-wide rules live here: every stream has at most one consumer (the
hardware ORs the readies of its consumers) and no chain of functionalities closes a cycle. An
external input is a stream like any other: its own slot reads it (selector 1) or any slot of its
cluster through the local crossbar, one of them at a time. Two selector values may name one
source (the ring and the local crossbar both reach a neighbour in the cluster, selector 1 and the
local crossbar both reach the slot's own input); the wrapper compares values, so taking one
source through both is refused here, as two consumers.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from .errors import RouteError
from .fabric import INPUT_SEL, NO_SOURCE, NONE_SEL, Fabric, Source, SourceKind


@dataclass(frozen=True)
class SlotRoute:
    """One wrapper's routing state: the functionality's source and the output port's source."""

    fsel: int
    osel: int


@dataclass(frozen=True)
class Path:
    """A complete route from an external input to an external output through functionalities."""

    input: int
    functions: tuple[int, ...]
    output: int


class Configuration:
    """The routing state of every wrapper in a fabric, checked as a whole."""

    def __init__(self, fabric: Fabric, routes: tuple[SlotRoute, ...]) -> None:
        if len(routes) != fabric.n:
            raise RouteError(f"expected {fabric.n} slot routes, got {len(routes)}")
        self.fabric = fabric
        self.routes = routes
        self._consumers = self._index_consumers()
        self._check_cycles()
        self._paths = {path.input: path for path in self.paths()}
        self._outputs = {port: path.output for port, path in self._paths.items()}

    @classmethod
    def reset(cls, fabric: Fabric) -> Configuration:
        """The routing after reset: input i -> functionality i -> output i."""
        return cls(
            fabric,
            tuple(SlotRoute(INPUT_SEL, fabric.self_selector(i)) for i in range(fabric.n)),
        )

    def with_route(self, slot: int, route: SlotRoute) -> Configuration:
        """This configuration with one wrapper changed (what a partial bitstream does)."""
        self.fabric.check_slot(slot)
        routes = list(self.routes)
        routes[slot] = route
        return Configuration(self.fabric, tuple(routes))

    def function_source(self, slot: int) -> Source:
        """What feeds ``slot``'s functionality."""
        return self.fabric.source(slot, self.routes[slot].fsel)

    def output_source(self, slot: int) -> Source:
        """What drives ``slot``'s output port."""
        return self.fabric.source(slot, self.routes[slot].osel)

    def consumer(self, source: Source) -> tuple[str, int] | None:
        """Who takes ``source``: ("function", slot), ("output", slot) or None."""
        return self._consumers.get(source)

    def paths(self) -> list[Path]:
        """Every complete route from an external input to an external output."""
        found = []
        for slot in range(self.fabric.n):
            path = self.trace(slot)
            if path is not None:
                found.append(path)
        return found

    def require_routes(self, inputs: Iterable[int]) -> dict[int, int]:
        """The output port each external input of `inputs` reaches, by input; RouteError for
        one the routing takes to no output (a beat sent there would wait forever). The routes
        are traced once per configuration (a load makes a new one), not on every call: a
        node's fabric PBO asks every cycle."""
        outputs: dict[int, int] = {}
        for port in inputs:
            self.fabric.check_slot(port)
            output = self._outputs.get(port)
            if output is None:
                raise RouteError(f"expected a route from input {port} to an output, got none")
            outputs[port] = output
        return outputs

    def route_of(self, input_slot: int) -> Path | None:
        """The route from external input ``input_slot`` (traced once per configuration: the
        model's `stream` asks on every call), or None if it ends nowhere."""
        return self._paths.get(input_slot)

    def trace(self, input_slot: int) -> Path | None:
        """Follow external input ``input_slot`` to its output, or None if it ends nowhere."""
        source = Source(SourceKind.INPUT, input_slot)
        functions: list[int] = []
        while True:
            taker = self.consumer(source)
            if taker is None:
                return None
            role, slot = taker
            if role == "output":
                return Path(input_slot, tuple(functions), slot)
            functions.append(slot)
            source = Source(SourceKind.FUNCTION, slot)

    def describe(self) -> str:
        """One line per route, e.g. ``in0 -> fn0 -> fn1 -> out1``."""
        lines = []
        for path in self.paths():
            hops = [f"in{path.input}", *(f"fn{k}" for k in path.functions), f"out{path.output}"]
            lines.append(" -> ".join(hops))
        return "\n".join(lines)

    def _index_consumers(self) -> dict[Source, tuple[str, int]]:
        consumers: dict[Source, tuple[str, int]] = {}
        for slot in range(self.fabric.n):
            for role, source in (
                ("function", self.function_source(slot)),
                ("output", self.output_source(slot)),
            ):
                if source == NO_SOURCE:
                    continue
                if source in consumers:
                    first = consumers[source]
                    raise RouteError(
                        f"expected one consumer of {source}, got the {role} of slot {slot} "
                        f"besides the {first[0]} of slot {first[1]}"
                    )
                consumers[source] = (role, slot)
        return consumers

    def _check_cycles(self) -> None:
        for start in range(self.fabric.n):
            seen = {start}
            source = Source(SourceKind.FUNCTION, start)
            while (taker := self.consumer(source)) is not None and taker[0] == "function":
                if taker[1] in seen:
                    raise RouteError(
                        f"expected no cycle of functionalities, got one through slot {taker[1]}"
                    )
                seen.add(taker[1])
                source = Source(SourceKind.FUNCTION, taker[1])


def bypass_route() -> SlotRoute:
    """The slot's functionality removed: its input goes straight to its output."""
    return SlotRoute(NONE_SEL, INPUT_SEL)


def through_route(fabric: Fabric, slot: int) -> SlotRoute:
    """The slot's functionality inserted: input -> functionality -> output (the reset route)."""
    return SlotRoute(INPUT_SEL, fabric.self_selector(slot))


def empty_route() -> SlotRoute:
    """The slot takes nothing and drives nothing."""
    return SlotRoute(NONE_SEL, NONE_SEL)
