"""The caller's model of the world around a managed task: `Plant`, the hook the manager consults.

ReFrESH judges a task by what its evaluators report; the world the task acts on (a target, a
track, a tank) is the caller's. A plant lets the caller take part in a managed run without
driving the runtime itself: it is asked for the live inputs the estimators start from at each
decision, looks at the world every `sample_period` seconds (a camera frame, a pose), starts what
must run before the task (a device that feeds it), hears of each switch and of each robot that
rejoins, and schedules its own events (a fault that strikes at a time of the run). The base class
does nothing, which is what a task whose world is all in its modules needs.

A plant reads the run through a `View`: the run's time, a port of the module filling a schema in
the running configuration (on whichever robot it runs), a port on a robot's node, the applier and
the runtime themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from pbort.code import ModuleCode
from refresh.appliers.base import ApplierBase, Inventory
from refresh.configuration import Configuration

if TYPE_CHECKING:
    from refresh.runtime import Runtime

Event = tuple[float, Callable[["View"], None]]
"""Something the plant does at a time of the run (seconds)."""


class View:
    """What a plant may see and touch of a run: `runtime` (its clock, history and database) and
    `applier` (the robots' nodes)."""

    def __init__(self, runtime: Runtime, applier: ApplierBase) -> None:
        self.runtime = runtime
        self.applier = applier

    @property
    def now(self) -> float:
        """Seconds of the run."""
        return self.runtime.clock()

    @property
    def running(self) -> bool:
        """Whether a configuration runs (not before the deployment, nor after a safe stop)."""
        return self.runtime.current is not None

    def value(self, schema: str, port: str) -> float:
        """A scalar port of the module filling `schema` in the running configuration."""
        return self.runtime.value(schema, port)

    def read(self, robot: str, port: str) -> float:
        """A scalar port (``PBO.port``) on `robot`'s node."""
        return self.applier.read(robot, port)

    def values(self, *slots: tuple[str, str]) -> list[float]:
        """Scalar ports of the modules filling slots, each (schema, port), in order: as `value`
        each, read with one request per robot."""
        return self.reads(*(self.runtime.where(schema, port) for schema, port in slots))

    def reads(self, *ports: tuple[str, str]) -> list[float]:
        """Scalar ports, each (robot, ``PBO.port``), in order: as `read` each, read with one
        request per robot (a look at a world over links costs a round trip per robot, not one
        per port)."""
        wanted: dict[str, list[str]] = {}
        for robot, port in ports:
            if port not in wanted.setdefault(robot, []):
                wanted[robot].append(port)
        got = {
            (robot, port): value
            for robot, names in wanted.items()
            for port, value in zip(names, self.applier.reads(robot, names), strict=True)
        }
        return [got[where] for where in ports]


class Plant:
    """The world around a task, as the caller models it; every hook does nothing by default."""

    sample_period: float | None = None
    """Seconds between two looks at the world (None: once per decision period). The runtime's
    decision period must be a whole number of them."""

    def natives(self) -> Mapping[str, ModuleCode]:
        """The native modules' code the manager's host estimates with, by name or by
        ``Module@robot``, beyond those it loads itself (``--natives``): code bound to the
        plant's own devices."""
        return {}

    def events(self) -> list[Event]:
        """What the plant does at given times of the run."""
        return []

    def start(self, view: View) -> None:
        """Once the nodes are reached, before the task is deployed."""

    def inputs(self, view: View) -> Mapping[str, object]:
        """The live values the estimators start from at a decision (``module.port``)."""
        return {}

    def look(self, view: View) -> None:
        """Every `sample_period` seconds of the run, once the world has run that far."""

    def switched(self, view: View, configuration: Configuration) -> None:
        """A configuration runs (the first, deployed, or a repair's)."""

    def rejoined(self, view: View, robot: str, inventory: Inventory) -> None:
        """Lost `robot`'s node is back and counted again; `inventory` is what it had."""
