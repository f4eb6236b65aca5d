"""The Morphing Bus: peripheral boards on a node's external ports, and the partial bitstreams that
keep each board's stream on its own internal modules when boards are plugged, unplugged or
swapped (Fig. 6 of the paper: the boards plug into the base board through the local crossbar;
swap them and the internal interconnection follows them).

A board (`Board`) is known by the word it identifies itself with and by its chain: the slots
whose functionalities its stream crosses, in order, before it comes back out of the board's own
port. The bus owns every external port: a port holds a board (its input feeds the board's first
module, its output shows the board's last one) or is parked (nothing reads its input, its output
shows nothing). A board's internal links (module to module) stay in place when it leaves, so a
board that comes back, or moves, only has its two ends re-plugged.

Identification: a board's first beat after it is plugged is its identification word, a packet
of one beat. On a parked port nothing takes it (the port's ready stays low), so it waits on the
port's lines, where the node reads it (`identify`, then `plug`). Once `plug`'s bitstreams are
loaded, the new route takes the held word as the first beat of the board's stream: it crosses
the board's modules and comes back to the board, its acknowledgement. Backpressure holds the
board's stream until its route exists, so no beat is lost or misrouted whatever the timing.

Every call returns the bitstreams to load, in order, and expects them loaded before the next
call. Only the wrappers whose routing changes get one; a wrapper that must let go of a stream
before another wrapper takes it (two boards exchanging ports) gets two, the first detaching it,
so that every routing on the way is one the fabric carries (`Configuration`'s checks, which the
transaction-level model applies to every load). A board's stream must be stopped, and its beats
back, before the board moves: the frames re-plug drained routes only.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from itertools import pairwise

from .bitstream import PartialBitstream, pack
from .errors import BusError, RouteError, UnknownBoardError
from .fabric import NO_SOURCE, NONE_SEL, Fabric, Source, SourceKind
from .routing import Configuration, Path, SlotRoute

Sink = tuple[str, int]
"""A selector that reads a stream: ("function", slot) is FSEL, ("output", slot) is OSEL."""


@dataclass(frozen=True)
class Board:
    """A peripheral board the node knows: its name, the word it identifies itself with (its
    first beat after a plug) and the slots whose functionalities its stream crosses, in order."""

    name: str
    ident: int
    chain: tuple[int, ...]

    def __post_init__(self) -> None:
        if not self.chain or len(set(self.chain)) != len(self.chain):
            raise BusError(
                f"expected {self.name}'s chain to name one or more distinct slots, got {self.chain}"
            )


class MorphingBus:
    """The boards on a fabric's external ports and the routing that serves them.

    ``boards`` is the catalogue (every board the node may meet); ``configuration`` is what the
    wrappers hold now (the reset routing by default). No board is on a port at first: call
    `park_free_ports` once, and load its bitstreams, before the first board is plugged.
    """

    def __init__(
        self,
        fabric: Fabric,
        boards: Iterable[Board],
        configuration: Configuration | None = None,
    ) -> None:
        self.fabric = fabric
        self.configuration = configuration or Configuration.reset(fabric)
        self._catalogue = self._checked_catalogue(boards)
        self._placement: dict[int, Board] = {}

    @property
    def placement(self) -> dict[int, Board]:
        """The board on each occupied port."""
        return dict(self._placement)

    def identify(self, word: int) -> Board:
        """The board that identifies itself with ``word``."""
        board = self._catalogue.get(word)
        if board is None:
            known = ", ".join(f"{b.ident:#x} ({b.name})" for b in self._catalogue.values())
            raise UnknownBoardError(
                f"expected a board's identification word ({known}), got {word:#x}"
            )
        return board

    def path(self, port: int) -> Path:
        """The route the board on ``port`` must have: from its port, through its chain, back."""
        return Path(port, self._occupied(port).chain, port)

    def park_free_ports(self) -> list[PartialBitstream]:
        """Bitstreams that park every port without a board (after reset every port is routed
        through its own slot, so a board's identification word would be taken at once)."""
        return self._move(dict(self._placement))

    def plug(self, port: int, word: int) -> list[PartialBitstream]:
        """The board identified by ``word`` (read on parked ``port``) is plugged there: the
        bitstreams that route its stream through its chain and back to ``port``."""
        self._check_port(port)
        board = self.identify(word)
        if port in self._placement:
            raise BusError(
                f"expected port {port} free for {board.name}, got {self._placement[port].name} "
                f"on it (unplug it first)"
            )
        for other, placed in self._placement.items():
            if placed == board:
                raise BusError(
                    f"expected {board.name} unplugged before it is plugged into port {port}, "
                    f"got it still on port {other}"
                )
        return self._move({**self._placement, port: board})

    def unplug(self, port: int) -> list[PartialBitstream]:
        """The board on ``port`` left (its stream stopped and drained): the bitstreams that
        park the port."""
        self._occupied(port)
        return self._move({p: b for p, b in self._placement.items() if p != port})

    def swap(self, a: int, b: int) -> list[PartialBitstream]:
        """The boards on ports ``a`` and ``b`` exchange places (both streams stopped and
        drained): the bitstreams that bring each board's stream to its own modules from its
        new port, fewer than unplugging and plugging both. For a node that knows of the
        exchange before the boards send again (the ports are not parked in between, so a board
        must wait for the bitstreams); a node that learns of it from the boards unplugs both
        and plugs each board it identifies."""
        if a == b:
            raise BusError(f"expected two different ports to swap, got port {a} twice")
        board_a, board_b = self._occupied(a), self._occupied(b)
        return self._move({**self._placement, a: board_b, b: board_a})

    def _checked_catalogue(self, boards: Iterable[Board]) -> dict[int, Board]:
        """The catalogue by identification word, once every board could be served: one board
        a word, a word that fits a beat, a chain of this fabric's slots that it can wire."""
        catalogue: dict[int, Board] = {}
        for board in boards:
            if not 0 <= board.ident < 1 << self.fabric.data_w:
                raise BusError(
                    f"expected {board.name}'s identification word below 2**{self.fabric.data_w} "
                    f"(one beat), got {board.ident}"
                )
            if board.ident in catalogue:
                first = catalogue[board.ident].name
                raise BusError(
                    f"expected one board per identification word, got {first} and {board.name} "
                    f"both sending {board.ident:#x}"
                )
            self._check_chain(board)
            catalogue[board.ident] = board
        return catalogue

    def _check_chain(self, board: Board) -> None:
        """Refuse a chain with a slot outside the fabric or a link no selector can make."""
        for slot in board.chain:
            if not 0 <= slot < self.fabric.n:
                raise BusError(
                    f"expected {board.name}'s chain in slots 0..{self.fabric.n - 1}, got {slot}"
                )
        for before, after in pairwise(board.chain):
            try:
                self.fabric.selector(after, Source(SourceKind.FUNCTION, before))
            except RouteError as error:
                raise BusError(f"cannot chain {board.name}'s modules: {error}") from None

    def _check_port(self, port: int) -> None:
        if not 0 <= port < self.fabric.n:
            raise BusError(f"expected a port in 0..{self.fabric.n - 1}, got {port}")

    def _occupied(self, port: int) -> Board:
        """The board on ``port``; BusError for a port outside the fabric or a free one."""
        self._check_port(port)
        board = self._placement.get(port)
        if board is None:
            raise BusError(f"expected a board on port {port}, got a free port")
        return board

    def _move(self, placement: dict[int, Board]) -> list[PartialBitstream]:
        """The bitstreams from the current routing to the one serving ``placement``; the bus
        takes both on (nothing changes when the placement is refused)."""
        target = self._target(placement)
        bitstreams = self._plan(target)
        self._placement = placement
        self.configuration = target
        return bitstreams

    def _target(self, placement: dict[int, Board]) -> Configuration:
        """The routing that serves ``placement``: each board's links; every other port parked;
        a selector that reads a port, or a module some board now needs, let go; any other link
        (a chain whose board left, a route of the node's own) kept."""
        links = self._links(placement)
        claimed = set(links.values())
        routes = []
        for slot in range(self.fabric.n):
            function = links.get(("function", slot))
            if function is None:
                kept = self.configuration.function_source(slot)
                function = NO_SOURCE if kept.kind is SourceKind.INPUT or kept in claimed else kept
            output = links.get(("output", slot), NO_SOURCE)
            routes.append(
                SlotRoute(self.fabric.selector(slot, function), self.fabric.selector(slot, output))
            )
        return Configuration(self.fabric, tuple(routes))

    def _links(self, placement: dict[int, Board]) -> dict[Sink, Source]:
        """What each selector a board needs must read: its port's input into its first module,
        module into module, its last module onto its port's output."""
        links: dict[Sink, Source] = {}
        users: dict[int, str] = {}
        for port, board in sorted(placement.items()):
            for slot in board.chain:
                if slot in users:
                    raise BusError(
                        f"expected {board.name}'s modules (slots {board.chain}) free, got slot "
                        f"{slot} in use by {users[slot]}"
                    )
                users[slot] = board.name
            source = Source(SourceKind.INPUT, port)
            sinks = [*(("function", slot) for slot in board.chain), ("output", port)]
            for sink in sinks:
                try:
                    self.fabric.selector(sink[1], source)
                except RouteError as error:
                    raise BusError(f"cannot route {board.name} on port {port}: {error}") from None
                links[sink] = source
                source = Source(SourceKind.FUNCTION, sink[1])
        return links

    def _plan(self, target: Configuration) -> list[PartialBitstream]:
        """The bitstreams from the current routing to ``target``, one per changed wrapper in an
        order where every step is a routing the fabric carries; when no changed wrapper can take
        its new route yet, one lets go of the streams it must give up first (a second bitstream
        for it). Every wrapper either holds its new selector or none, so its new route is then
        a subset of ``target``'s streams and can always be taken."""
        current = self.configuration
        pending = [s for s in range(self.fabric.n) if current.routes[s] != target.routes[s]]
        bitstreams = []
        while pending:
            slot, route = self._next_step(current, target, pending)
            current = current.with_route(slot, route)
            bitstreams.append(pack(self.fabric, slot, route))
            if route == target.routes[slot]:
                pending.remove(slot)
        return bitstreams

    @staticmethod
    def _next_step(
        current: Configuration, target: Configuration, pending: list[int]
    ) -> tuple[int, SlotRoute]:
        """A pending wrapper and the route to give it next: its new route if the routing
        carries it now, or else the first one's selectors that change, let go."""
        for slot in pending:
            try:
                current.with_route(slot, target.routes[slot])
            except RouteError:
                continue
            return slot, target.routes[slot]
        for slot in pending:
            detached = _detached(current.routes[slot], target.routes[slot])
            if detached != current.routes[slot]:
                return slot, detached
        raise AssertionError("no step towards a valid target routing")  # see _plan's docstring


def _detached(route: SlotRoute, target: SlotRoute) -> SlotRoute:
    """``route`` with each selector that ``target`` changes set to none."""
    return SlotRoute(
        route.fsel if route.fsel == target.fsel else NONE_SEL,
        route.osel if route.osel == target.osel else NONE_SEL,
    )
