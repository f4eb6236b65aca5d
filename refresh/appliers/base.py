"""The appliers' base: what every applier does, whatever runs the robots.

The Maintainer's plan is carried out by an applier, one public method per kind of step
(`Applier`: disconnect, stop, migrate, start, connect); the runtime also reads through it what
runs (`sources`, `read`) and the robots' outages (`lost`, `rejoin`). `ApplierBase` holds what
every back end does alike, as python-can's `BusABC` does for its interfaces: each public method
does the bookkeeping and calls one protected hook that the back end implements.

- **Bridges.** A connection between two robots (a coalition) is a bridge: an exporting PBO
  ``bridge{N}_tx`` on the source robot and an importing one ``bridge{N}_rx`` on the sink's, each
  at its module's rate, numbered by the applier. The base numbers them, keeps them by sink, takes
  down the bridges of a PBO that stops or of an input that is disconnected, and forgets those with
  a half on a robot that was lost; the back end puts up and stops the halves (`_bridge`,
  `_stop_pbo`).
- **Outages.** A robot is lost (its node gone, silent, or switched off) when `lost` names it; a
  step on a lost robot asks nothing of its node: stopping what ran there, or taking down a
  bridge's half there, only forgets it, and adding anything there is refused. `rejoin` reaches a
  lost robot's node again and says what it has (`Inventory`).
- **Images and migrations.** The image to migrate is the one given for the module, else the file
  the database names. It is not sent when the robot lists a module of that name with the
  image's size and the CRC-32 of the image relocated to the listed address (what a node's
  listing says: a module edited and rebuilt since is sent again, in place of the old one), and
  the step's line says which it was (`migrate` and `stop` return a note for it). Each migration
  is recorded (`Migration`); with a modelled wire (`migration_wire`), the transfer takes that
  wire's time in the run: the back end says how long (`_send`), and `wait(seconds)` lets the
  world run on meanwhile (the old configuration keeps working while the image travels, as on a
  real robot).
- **Reads.** `read` gives a live scalar port's value as a float, or an ApplyError naming the port;
  `reads` several ports of one robot at once (one request over a link).

The back ends live beside this module: `in_memory` (a model of the robots, for tests of plans),
`in_process` (emulated nodes in this process) and `over_links` (node processes or boards reached
by URL).
"""

from __future__ import annotations

import zlib
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from firmware_sim.wires.transfer import WireRun
from hexmigrate.image import ModuleImage
from hexmigrate.transfer.control import LoggedLine
from hexmigrate.transfer.fields import ListedModule
from morphing_crossbar.hex_image import configuration_cycles
from refresh.database import Module
from refresh.decider import PerformanceSource
from refresh.errors import ApplyError, NodeLinkError
from refresh.hardware import bitstream_images
from refresh.images import migration_image
from refresh.remote.reports import Slip

ModuleLine = tuple[str, str, LoggedLine]
"""A line a module logged: the robot, the PBO and the line (number, node time, text)."""


class Applier(Protocol):
    """Carries out plan steps on the robots (what the Maintainer needs)."""

    def disconnect(self, robot: str, sink: str) -> None:
        """Unbind input port `sink` (``instance.port``) on `robot`."""

    def stop(self, robot: str, instance: str) -> str | None:
        """Switch PBO `instance` off, kill it and remove it from `robot`'s kernel, from
        whatever state it is in (a PBO that faulted is in ERROR); a note for the step's line
        when it was not running (None when it was)."""

    def migrate(self, robot: str, module: Module) -> str | None:
        """Make `module`'s image installed on `robot` (nothing to send if it already is); a
        note for the step's line when it did otherwise than send the image to a robot without
        the module (None when it did just that): not sent, or sent in place of another."""

    def start(self, robot: str, instance: str, module: Module) -> None:
        """Register `module` as PBO `instance` on `robot`, set its constants, init it, switch on."""

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Bind input `sink` on `robot` to output `source` on `source_robot`."""


@dataclass(frozen=True)
class Inventory:
    """What a node that rejoined has: its modules (in flash) and its PBOs with their states
    (``ON``, ``OFF``, ``ERROR``)."""

    modules: tuple[str, ...]
    pbos: tuple[tuple[str, str], ...]

    def running(self) -> tuple[str, ...]:
        """The PBOs that are on."""
        return tuple(name for name, state in self.pbos if state == "ON")


@dataclass(frozen=True)
class Bridge:
    """A bridge an applier put up: `source` on `source_robot` feeds `sink` on `sink_robot`
    through PBOs ``bridge{number}_tx`` and ``bridge{number}_rx``."""

    number: int
    source_robot: str
    source: str
    sink_robot: str
    sink: str

    def halves(self) -> tuple[tuple[str, str], tuple[str, str]]:
        """(robot, PBO) of the importer, then of the exporter."""
        return (
            (self.sink_robot, f"bridge{self.number}_rx"),
            (self.source_robot, f"bridge{self.number}_tx"),
        )

    def touches(self, robot: str, instance: str) -> bool:
        """Whether PBO `instance` on `robot` owns one of the two ports."""
        return (robot, instance) in (
            (self.source_robot, owner(self.source)),
            (self.sink_robot, owner(self.sink)),
        )

    def robots(self) -> tuple[str, str]:
        """The robots of the source and of the sink."""
        return self.source_robot, self.sink_robot


@dataclass(frozen=True)
class Migration:
    """One module's image sent to a robot (or a hardware module's partial bitstreams, with
    `hardware`, and the fabric `cycles` their reconfigurations took): when it started (seconds
    of the run), its size, and, on a modelled wire, the time the transfer took there, the wire
    and its rate (``serial 115200``) and the bits it put on the wire both ways."""

    module: str
    robot: str
    start: float
    size: int
    seconds: float = 0.0
    wire: str = ""
    bits: int = 0

    hardware: bool = False
    cycles: int = 0

    @classmethod
    def of(
        cls,
        module: Module,
        robot: str,
        start: float,
        size: int,
        runs: Sequence[WireRun | None],
        cycles: int = 0,
    ) -> Migration:
        """The record of the transfers of one module's images (one, or a hardware module's
        bitstreams, which reconfigured its robot's fabric in `cycles` fabric cycles), timed on
        the modelled wire they went over (if any)."""
        hardware = module.hardware is not None
        timed = [run for run in runs if run is not None]
        if not timed:
            return cls(module.name, robot, start, size, hardware=hardware, cycles=cycles)
        seconds = sum(run.seconds for run in timed)
        bits = sum(run.host.total_bits() + run.node.total_bits() for run in timed)
        wire = f"{timed[0].wire} {timed[0].rate:g}"
        return cls(module.name, robot, start, size, seconds, wire, bits, hardware, cycles)


class ApplierBase(ABC):
    """What every applier does; a back end implements the protected hooks.

    `images` may give a module's image instead of the file the database names;
    `migration_wire` (``serial``, ``can``, at the wire's default rate; None: no wire time)
    models the wire a migration crosses, and `wait(seconds)` lets the world run on while it
    does; `clock()` dates each migration (seconds of the run).
    """

    def __init__(
        self,
        *,
        images: Mapping[str, ModuleImage] | None = None,
        migration_wire: str | None = None,
        wait: Callable[[float], None] = lambda seconds: None,
        clock: Callable[[], float] = lambda: 0.0,
    ) -> None:
        self.images = dict(images or {})
        self.migration_wire = migration_wire
        self.wait = wait
        self.clock = clock
        self.bridges: dict[tuple[str, str], Bridge] = {}
        """The bridges by (sink robot, sink port)."""
        self.migrations: list[Migration] = []
        """Every image sent, in order."""
        self.frequencies: dict[tuple[str, str], float] = {}
        """(robot, PBO) -> the rate it was started at, for the bridges that carry its ports."""
        self.issued = 0
        """How many bridges were numbered so far: the next one's number."""
        self.hardware: dict[tuple[str, str], Module] = {}
        """(robot, PBO) -> the hardware module it was started as: its slots are emptied when
        it stops."""
        self.configured: dict[str, dict[int, str]] = {}
        """The hardware module each fabric slot was configured for, by robot and slot: a slot
        another module took is configured again when its module starts anew."""
        self.logs_seen: dict[tuple[str, str], int] = {}
        """(robot, PBO) -> the number of its module's latest log line `module_logs` gave."""
        self.down: set[str] = set()
        """Robots known to be down, for an outage the caller knows of that is not over yet:
        `rejoin` does not try them (a node restarted early in wall time must not rejoin a run
        in virtual time before its outage ends)."""

    # What the runtime reads.

    @abstractmethod
    def robots(self) -> Iterable[str]:
        """The robots this applier drives."""

    @abstractmethod
    def sources(self) -> Mapping[str, PerformanceSource]:
        """Each robot's performance source (the evaluators' reports), by robot."""

    def slipped(self) -> Mapping[str, Slip]:
        """The robots whose node slipped behind real time since the last call, with how far:
        none for nodes on a virtual clock (the in-process back ends); nodes over links say so
        in their reports (`refresh.remote.reports`)."""
        return {}

    def module_logs(self) -> list[ModuleLine]:
        """The lines the robots' modules logged since the last call, oldest first per PBO."""
        return []

    def stopped_bridges(self) -> list[str]:
        """What stopped carrying a bridge's values since the last call, one sentence each: the
        manager's own relays (a node that cannot export, `refresh.remote.relay`); none for
        bridges the nodes carry themselves."""
        return []

    def _unseen(self, robot: str, pbo: str, latest: int) -> int | None:
        """After which line to read PBO `pbo`'s log on `robot`, whose latest line is `latest`:
        None when nothing is new. A PBO met for the first time starts from its latest line
        unless the applier started it (the lines before are not this run's); one whose count
        went back is a new PBO of that name, read from its first line."""
        key = (robot, pbo)
        seen = self.logs_seen.setdefault(key, latest)
        if latest < seen:
            seen = self.logs_seen[key] = 0
        return seen if latest > seen else None

    def read(self, robot: str, port: str) -> float:
        """The live value of scalar port `port` (``instance.port``) on `robot`; a lost robot's
        back end says why it has none."""
        return self.reads(robot, (port,))[0]

    def reads(self, robot: str, ports: Sequence[str]) -> list[float]:
        """The live values of scalar ports (``instance.port`` each) on `robot`, in one request
        where the robot is reached by requests (a sample of several ports costs one round trip,
        not one each)."""
        self._known(robot)
        values = self._read(robot, tuple(ports))
        return [_scalar(robot, port, value) for port, value in zip(ports, values, strict=True)]

    @abstractmethod
    def _read(self, robot: str, ports: tuple[str, ...]) -> list[object]:
        """The live values of `ports` on `robot`, as the node holds them, in their order."""

    # Outages.

    @abstractmethod
    def lost(self, after: float) -> Mapping[str, str]:
        """The robots whose node is lost, with why: gone (a link that failed, a node powered
        off) or silent for `after` seconds."""

    @abstractmethod
    def is_lost(self, robot: str) -> bool:
        """Whether `robot`'s node is lost (a step there asks nothing of it)."""

    def rejoin(self, robot: str) -> Inventory | None:
        """Reach lost `robot`'s node again: what it has once it answers, else None. What this
        applier had made with a half on the robot (bridges) is forgotten, and their other halves
        taken down. A robot known to be `down` is not tried."""
        if robot in self.down:
            return None
        inventory = self._reach(robot)
        if inventory is None:
            return None
        # A restarted node's fabric is reset; one out of reach may have had its slots changed.
        self.configured.pop(robot, None)
        for key, bridge in list(self.bridges.items()):
            if robot in bridge.robots():
                del self.bridges[key]
                self._take_down(bridge, quiet=True)
        return inventory

    @abstractmethod
    def _reach(self, robot: str) -> Inventory | None:
        """Reach `robot`'s node again; what it has, else None."""

    def require(self, robot: str) -> None:
        """Refuse a robot this applier does not drive, or one whose node is lost."""
        self._known(robot)
        if self.is_lost(robot):
            raise ApplyError(f"robot {robot!r}: its node is lost")

    def _known(self, robot: str) -> None:
        """Refuse a robot this applier does not drive."""
        robots = list(self.robots())
        if robot not in robots:
            raise ApplyError(
                f"robot {robot!r}: expected one of {', '.join(robots)}, got no such node"
            )

    # The plan's steps.

    def disconnect(self, robot: str, sink: str) -> None:
        """Unbind input `sink` on `robot`: take down the bridge that fed it, or undo the wire."""
        bridge = self.bridges.pop((robot, sink), None)
        if bridge is not None:
            self._take_down(bridge)
            return
        self._disconnect(robot, sink)

    def stop(self, robot: str, instance: str) -> str | None:
        """Take down the bridges to and from PBO `instance`, then stop it, from whatever state
        it is in (a PBO that faulted into ERROR, the one a repair most often switches away from,
        is taken out too); its image stays installed for a later start, but a hardware module's
        slots are emptied (its wrappers let go of their streams, so that another module's
        bitstreams may route those slots). On a lost robot it is only forgotten. A note for the
        step's line when the PBO was not running (the back end's), else None."""
        for key, bridge in list(self.bridges.items()):
            if bridge.touches(robot, instance):
                del self.bridges[key]
                self._take_down(bridge)
        self.frequencies.pop((robot, instance), None)
        note = self._stop(robot, instance)
        module = self.hardware.pop((robot, instance), None)
        if module is not None and module.hardware is not None:
            self._release(robot, module.name, module.hardware.slots)
        return note

    def _release(self, robot: str, module: str, slots: Sequence[int]) -> None:
        """Empty the `slots` of `robot`'s fabric still configured for `module` (a lost robot's
        are only forgotten: its node is gone or will be sent them again)."""
        configured = self.configured.get(robot, {})
        for slot in slots:
            if configured.get(slot) == module:
                del configured[slot]
                if not self.is_lost(robot):
                    self._unload(robot, slot)

    def migrate(self, robot: str, module: Module) -> str | None:
        """Send the module's image to the robot unless it is installed there already (a
        hardware module's bitstreams unless its slots are configured for it); with a modelled
        wire, let the world run on for as long as the transfer takes. A note for the step's
        line when nothing was sent (the robot has it) or the image replaced another of the
        module's name, else None.

        A module is installed already when the robot lists one of its name, of the image's size
        and of the CRC-32 the image has relocated to the listed address (`same_image`).
        Comparing matters because nodes outlive managers: a module edited and rebuilt since the
        node got it is sent again (it replaces the old one), where a name alone would leave the
        old code running while the step said it migrated. The note says what was compared, so
        that the line does not claim a migration."""
        self.require(robot)
        if module.source.native:
            raise ApplyError(
                f"migrate {module.name} to {robot}: expected an image, got native code"
            )
        images = self._images(module)
        kept, note = self._holds(robot, module, images)
        if kept is not None:
            return kept
        hardware = module.hardware is not None
        start = self.clock()
        if module.hardware is not None:  # its slots' state is not known until all are in
            for slot in module.hardware.slots:
                self.configured.get(robot, {}).pop(slot, None)
        size, runs, cycles = 0, [], 0
        for image in images:
            registered, sent, run = self._send(robot, module, image)
            if not hardware and registered != module.name:
                raise ApplyError(
                    f"migrate {module.name} to {robot}: expected the image to register "
                    f"{module.name!r}, got {registered!r}"
                )
            size, runs = size + sent, [*runs, run]
            if hardware and image is not None:
                cycles += configuration_cycles(image)
        if module.hardware is not None:
            slots = self.configured.setdefault(robot, {})
            slots.update(dict.fromkeys(module.hardware.slots, module.name))
        migration = Migration.of(module, robot, start, size, runs, cycles)
        self.migrations.append(migration)
        if migration.seconds > 0:
            self.wait(migration.seconds)
        return note

    def _holds(
        self, robot: str, module: Module, images: Sequence[ModuleImage | None]
    ) -> tuple[str | None, str | None]:
        """Whether `robot` has what a migration of `module` would send (`images`): its image
        installed (a module of its name listed as the image, `same_image`; of its name alone
        where the back end models no images), or its fabric's slots configured for the hardware
        module. (a note that it was not sent, None) when it has, else (None, a note saying
        which module of that name the image replaces, None if none)."""
        if module.hardware is not None:
            configured = self.configured.get(robot, {})
            if all(configured.get(slot) == module.name for slot in module.hardware.slots):
                return f"slots already configured for it on {robot}, not sent", None
            return None, None
        listed = self._installed(robot, module.name)
        if listed is None:
            return None, None
        image = images[0]
        if image is None:
            return f"already on {robot}, not sent", None
        same, compared = same_image(listed, image)
        if same:
            return f"already on {robot} ({compared}), not sent", None
        return None, f"in place of the {module.name} on {robot} ({compared})"

    def _images(self, module: Module) -> Sequence[ModuleImage | None]:
        """What a migration of `module` sends: its image, or a hardware module's bitstreams (a
        back end that models robots without images says None for each)."""
        return bitstream_images(module) if module.hardware else [self.image_of(module)]

    def image_of(self, module: Module) -> ModuleImage:
        """The image to migrate: the one given for the module, else the file the database names."""
        return migration_image(module, self.images)

    def start(self, robot: str, instance: str, module: Module) -> None:
        """Start PBO `instance` of `module` with the database's rate and constants."""
        self.require(robot)
        self._start(robot, instance, module)
        self.frequencies[robot, instance] = module.frequency
        if module.hardware is not None:
            self.hardware[robot, instance] = module

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Bind the input to the output: on the robot's node when both are on one robot, else
        through a new bridge from the source's node to the sink's."""
        if source_robot == robot:
            self.require(robot)
            self._connect(robot, source, sink)
            return
        self.require(source_robot)
        self.require(robot)
        bridge = Bridge(self.issued, source_robot, source, robot, sink)
        self.issued += 1
        self._bridge(bridge)
        self.bridges[robot, sink] = bridge

    def _take_down(self, bridge: Bridge, *, quiet: bool = False) -> None:
        """Stop a bridge's two halves (a half on a lost robot went with its node), both tried
        even if the first fails, whose error is raised then (unless `quiet`)."""
        failed: ApplyError | NodeLinkError | None = None
        for robot, pbo in bridge.halves():
            if robot in self.robots() and not self.is_lost(robot):
                try:
                    self._stop_pbo(robot, pbo)
                except (ApplyError, NodeLinkError) as error:
                    failed = failed or error
        self._bridge_down(bridge)
        if failed is not None and not quiet:
            raise failed

    # The back end's hooks.

    @abstractmethod
    def _disconnect(self, robot: str, sink: str) -> None:
        """Undo the wire into `sink` on one robot (a lost one's only forgotten)."""

    @abstractmethod
    def _stop(self, robot: str, instance: str) -> str | None:
        """Stop PBO `instance` from whatever state it is in, ERROR included (its bridges are
        down already; a lost robot's only forgotten); a note when it was not running."""

    @abstractmethod
    def _installed(self, robot: str, module: str) -> ListedModule | None:
        """The module `module` as `robot`'s node lists it (a back end that models no images:
        address and size 0, no CRC), or None when it holds none."""

    @abstractmethod
    def _send(
        self, robot: str, module: Module, image: ModuleImage | None
    ) -> tuple[str, int, WireRun | None]:
        """Install `image` of `module` on `robot` (its image, or one of a hardware module's
        bitstreams; None from a back end whose `_images` gives none): the name it registered,
        its size in bytes, and the transfer on the modelled migration wire (None without one)."""

    @abstractmethod
    def _unload(self, robot: str, slot: int) -> None:
        """Empty `slot` of `robot`'s fabric: its wrapper takes and drives nothing."""

    @abstractmethod
    def _start(self, robot: str, instance: str, module: Module) -> None:
        """Start PBO `instance` with the module's rate and constants."""

    @abstractmethod
    def _connect(self, robot: str, source: str, sink: str) -> None:
        """Wire `source` into `sink`, both on `robot`."""

    @abstractmethod
    def _bridge(self, bridge: Bridge) -> None:
        """Put up `bridge`'s two halves."""

    @abstractmethod
    def _stop_pbo(self, robot: str, pbo: str) -> None:
        """Stop a bridge's half `pbo` on `robot` (not lost)."""

    @abstractmethod
    def _bridge_down(self, bridge: Bridge) -> None:
        """`bridge` was taken down: forget what the back end kept of it."""


def owner(port: str) -> str:
    """The PBO of ``PBO.port``."""
    return port.partition(".")[0]


def _scalar(robot: str, port: str, value: object) -> float:
    """`value` of `port` as a number; an ApplyError for a value that is not a scalar."""
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):  # an integer beyond a float's range
        raise ApplyError(
            f"read {port} on {robot}: expected a scalar value, got {type(value).__name__}"
        ) from None


def same_image(listed: ListedModule, image: ModuleImage) -> tuple[bool, str]:
    """Whether the module a node lists is `image`, and what was compared, in words for a step's
    line. The node's CRC-32 is of the bytes in its flash, relocated to the listed address, so
    the image is relocated there to compare (an address no image of its size fits at is
    another image). A node that lists no CRC is judged by the size alone, and the words say so."""
    if listed.size != image.size:
        return False, f"{listed.size} bytes on the node, {image.size} in the image"
    if listed.crc32 is None:
        return True, f"{image.size} bytes, as the image; the node lists no CRC-32"
    flash = f"CRC-32 0x{listed.crc32:08X} in its flash at 0x{listed.address:08X}"
    try:
        crc = zlib.crc32(image.relocate(listed.address))
    except ValueError:  # an address no image of this size fits at
        return False, f"{image.size} bytes as the image, but {flash}, where the image cannot lie"
    if crc != listed.crc32:
        moved = f"where the image would have 0x{crc:08X}"
        return False, f"{image.size} bytes as the image, but {flash}, {moved}"
    return (
        True,
        f"{image.size} bytes and CRC-32 0x{crc:08X} at 0x{listed.address:08X}, as the image",
    )
