"""The Maintainer: from the running configuration to the chosen one, step by step (section 5).

`plan` compares two configurations instance by instance. An instance whose placement is the same
in both keeps running untouched; the others are stopped, and the new ones started. Images go
first: a new module whose code is not native is migrated to its robot while the old configuration
still runs, so the switch that follows costs no transfer time. Connections follow: those that
change on a module that keeps running are taken down first (before the PBO feeding them goes
away), and every connection of the new configuration that did not exist is made once all its
modules run. The plan is applied through an `Applier`, a small protocol with one method per kind
of step, so the same plan drives any back end of `refresh.appliers` (an in-memory model, emulated
nodes in this process, nodes over links); each step is timed and logged.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from refresh.appliers.base import Applier
from refresh.configuration import Configuration
from refresh.database import ModuleDatabase, Placement
from refresh.events import EventLog

ORDER = ("migrate", "disconnect", "stop", "start", "connect")
"""The order the kinds of step run in: images travel while the old configuration still runs (but
a hardware module's bitstreams for slots a stopped hardware module holds, after the stop)."""


@dataclass(frozen=True)
class Step:
    """One step of a plan. `instance` is the PBO name (the sink's for connections); `source` and
    `source_robot` are the feeding port and its robot for ``connect``; `hardware` says that the
    module runs on the robot's FPGA fabric (its migration carries partial bitstreams)."""

    action: str
    robot: str
    instance: str
    module: str = ""
    source: str = ""
    source_robot: str = ""
    hardware: bool = False

    def __str__(self) -> str:
        if self.action == "connect":
            return f"connect {self.source}@{self.source_robot} -> {self.instance}@{self.robot}"
        if self.action == "disconnect":
            return f"disconnect {self.instance}@{self.robot}"
        if self.action == "migrate":
            carried = " (partial bitstreams to its fabric)" if self.hardware else ""
            return f"migrate {self.module} to {self.robot}{carried}"
        notes = [self.module] if self.module != self.instance else []  # a combo's Dehazer_2
        notes += ["in hardware"] if self.hardware else []
        said = f" ({', '.join(notes)})" if notes else ""
        return f"{self.action} {self.instance}{said} on {self.robot}"


@dataclass(frozen=True)
class Timing:
    """How long one step took, in seconds of the host's monotonic clock."""

    step: Step
    seconds: float


@dataclass(frozen=True)
class Plan:
    """The steps from one configuration to another, in the order they run."""

    steps: tuple[Step, ...]

    def __str__(self) -> str:
        return "\n".join(f"{n}. {s}" for n, s in enumerate(self.steps, start=1)) or "(no change)"


def plan(current: Configuration | None, target: Configuration, database: ModuleDatabase) -> Plan:
    """The steps from `current` (None: nothing runs yet) to `target`."""
    old = _instances(current)
    new = _instances(target)
    kept = {name for name, placement in new.items() if old.get(name) == placement}
    old_wiring = set(current.connections(database)) if current is not None else set()
    new_wiring = set(target.connections(database))
    steps: list[Step] = []
    for _source, sink in sorted(old_wiring - new_wiring):
        if _owner(sink) in kept:
            steps.append(Step("disconnect", new[_owner(sink)].robot, sink))
    for name, placement in old.items():
        if name not in kept:
            hardware = database.module(placement.module).hardware is not None
            steps.append(Step("stop", placement.robot, name, placement.module, hardware=hardware))
    installed = {(p.module, p.robot) for p in old.values()}
    for name, placement in new.items():
        if name in kept:
            continue
        module = database.module(placement.module)
        hardware = module.hardware is not None
        if not module.source.native and (placement.module, placement.robot) not in installed:
            steps.append(
                Step("migrate", placement.robot, name, placement.module, hardware=hardware)
            )
            installed.add((placement.module, placement.robot))
        steps.append(Step("start", placement.robot, name, placement.module, hardware=hardware))
    for source, sink in target.connections(database):
        if (source, sink) not in old_wiring or not {_owner(source), _owner(sink)} <= kept:
            steps.append(
                Step(
                    "connect", new[_owner(sink)].robot, sink, "", source, new[_owner(source)].robot
                )
            )
    late = _clashing_migrations(steps, database)
    return Plan(tuple(sorted(steps, key=lambda s: _rank(s, late))))


def _clashing_migrations(steps: list[Step], database: ModuleDatabase) -> set[Step]:
    """The hardware migrations whose slots a hardware module stopped on the same robot holds:
    its wrappers must be let go (the stop empties them) before the new bitstreams route those
    slots, or the fabric would refuse a stream with two consumers."""
    held: dict[str, set[int]] = {}
    for step in steps:
        if step.action == "stop":
            held.setdefault(step.robot, set()).update(_slots(step, database))
    return {
        step
        for step in steps
        if step.action == "migrate" and held.get(step.robot, set()) & _slots(step, database)
    }


def _slots(step: Step, database: ModuleDatabase) -> set[int]:
    """The fabric slots the module of `step` uses (none for a software module)."""
    hardware = database.module(step.module).hardware
    return set() if hardware is None else set(hardware.slots)


def _rank(step: Step, late: set[Step]) -> float:
    """Where `step` runs: by its action (`ORDER`), a migration of `late` just after the stops."""
    if step in late:
        return ORDER.index("stop") + 0.5
    return ORDER.index(step.action)


def _instances(configuration: Configuration | None) -> dict[str, Placement]:
    if configuration is None:
        return {}
    return dict(zip(configuration.instances, configuration.placements, strict=True))


def _owner(port: str) -> str:
    return port.partition(".")[0]


class Maintainer:
    """Plans and applies reconfigurations through `applier`, logging every step and its time."""

    def __init__(
        self,
        database: ModuleDatabase,
        applier: Applier,
        log: EventLog,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.database = database
        self.applier = applier
        self.log = log
        self.clock = clock

    def plan(self, current: Configuration | None, target: Configuration) -> Plan:
        """The plan from `current` to `target`, recorded in the log."""
        result = plan(current, target, self.database)
        self.log.record(
            "plan",
            f"{len(result.steps)} step(s) to {target.label()}",
            steps=[str(s) for s in result.steps],
            target=target.label(),
        )
        return result

    def apply(self, plan: Plan) -> list[Timing]:
        """Run every step in order; stop at the first that fails (the error propagates). A step
        the applier carried out otherwise than its words say (an image already on the robot,
        not sent; a PBO stopped out of ERROR) has the applier's note on its line and as `note`,
        so that the log never claims a migration that did not happen."""
        timings = []
        for step in plan.steps:
            start = self.clock()
            note = self._run(step)
            timing = Timing(step, self.clock() - start)
            timings.append(timing)
            said = str(step) if note is None else f"{step}: {note}"
            self.log.record(
                "step",
                f"{said} ({timing.seconds * 1e3:.3f} ms)",
                step=str(step),
                action=step.action,
                seconds=timing.seconds,
                **({} if note is None else {"note": note}),
            )
        total = sum(t.seconds for t in timings)
        self.log.record("applied", f"{len(timings)} step(s) in {total * 1e3:.3f} ms", seconds=total)
        return timings

    def _run(self, step: Step) -> str | None:
        """Carry `step` out; the applier's note on how, if it has one (migrate, stop)."""
        applier = self.applier
        if step.action == "disconnect":
            applier.disconnect(step.robot, step.instance)
        elif step.action == "stop":
            return applier.stop(step.robot, step.instance)
        elif step.action == "migrate":
            return applier.migrate(step.robot, self.database.module(step.module))
        elif step.action == "start":
            applier.start(step.robot, step.instance, self.database.module(step.module))
        else:
            applier.connect(step.robot, step.source, step.instance, step.source_robot)
        return None
