"""The world an application's robots act in, as the application models it: `WorldPlant`.

A plant is the manager's `refresh.manager.plant.Plant` (the live inputs of the estimators, a look
at the world every sample period, its own events, a switch, a robot back) plus what an
application's world must provide wherever a run's parts live (`Setting`):

- in process, beside the robots' nodes (`Setting.nodes`), on the world's virtual clock;
- in a robot's node process (`Setting.robot`), on that node's clock: its firmware;
- in the manager's process, beside nodes it reaches over links;

and what the run records: a `sample` of the world after every sample period. The base class is
the world of a task whose body is all in its modules (the patrol's chassis, the tank's gauge):
the natives are the application's classes, a sample is what the application's `observe` reads
of the running modules, and there is nothing else to model. An application with a world of its
own (the paper's scene, servos and plate) subclasses it.

Devices a plant reaches in other processes (a CAN bus to servos) come as URLs by name
(`Setting.devices`); a plant that needs processes of its own beside the nodes (a servo emulator)
starts them in `launch`, which says the devices' URLs it made and how to wait until they serve.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from firmware_sim.core.node import Node
from pbort.code import ModuleCode
from pbort.native import NativeModule
from refresh.database import ModuleDatabase
from refresh.manager.plant import Plant, View

if TYPE_CHECKING:
    from application.declaration import Application
    from application.launch import Launch
    from application.scenario import Scenario


@dataclass(frozen=True)
class Setting:
    """Where a plant is made: for `scenario` on `database`, on `clock` (seconds of the run);
    with `nodes` in process (every robot's node, stepped together), or for `robot`'s node
    process, or (neither) for the manager across processes; `devices` are the URLs of the
    plant's devices in other processes, by name; `horizon` is the time a node process's run
    goes to (`Node.horizon`: the end of its quantum in lock-step time), which it stamps on what
    it sends to those devices, and the clock elsewhere."""

    application: Application
    scenario: Scenario
    database: ModuleDatabase
    clock: Callable[[], float]
    nodes: Mapping[str, Node] | None = None
    robot: str | None = None
    devices: Mapping[str, str] = field(default_factory=dict)
    horizon: Callable[[], float] | None = None

    def stamp(self) -> float:
        """The time to stamp on what this setting sends to a device in another process."""
        return (self.horizon or self.clock)()


@dataclass(frozen=True)
class Launched:
    """What a plant's own processes are: its devices' URLs by name (the nodes are started with
    them), and `ready()`, which returns once they serve, waited for only when the manager starts
    (the nodes start meanwhile)."""

    devices: Mapping[str, str] = field(default_factory=dict)
    ready: Callable[[], None] = lambda: None


class WorldPlant(Plant):
    """The plant of `setting`: the world of a task whose body is all in its modules."""

    DEVICES: ClassVar[tuple[str, ...]] = ()
    """The names of the devices in other processes its nodes and manager take (``--device
    NAME=URL``): none for a world all in its modules."""

    def __init__(self, setting: Setting) -> None:
        self.setting = setting
        self.sample_period = setting.application.sample_period

    @classmethod
    def launch(cls, launch: Launch, lock_step: bool) -> Launched:
        """Start the plant's own processes for a run across processes (none here)."""
        return Launched()

    def natives(self) -> dict[str, ModuleCode]:
        """Every native module's code (the manager's host estimates with it, in process the
        nodes run it too), by name or ``Module@robot``."""
        return {name: NativeModule(cls) for name, cls in self.setting.application.natives.items()}

    def firmware(self, robot: str) -> dict[str, ModuleCode]:
        """The natives of `robot`'s node: those the database places on it."""
        placed = {m.name for m in self.setting.database.modules() if robot in m.robots}
        return {name: code for name, code in self.natives().items() if name in placed}

    def sample(self, view: View) -> Mapping[str, float]:
        """The world at this moment, as the run records it (the application's `observe`)."""
        return self.setting.application.observe(view)

    def inputs(self, view: View) -> Mapping[str, object]:
        """The live values the estimators start from (the application's `live_inputs`)."""
        return self.setting.application.live_inputs(view)

    def close(self) -> None:
        """Release what the plant opened."""
