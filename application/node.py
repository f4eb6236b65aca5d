"""A robot's node in its own process: ``python -m APP node --robot NAME --scenario NAME --listen
URL [--lock-step] [--flash FILE] [--kill-at S] [--device NAME=URL ...]``.

The program makes that robot's firmware from the application's plant (`WorldPlant.firmware`: the
natives the database places on the robot, bound to the plant's devices on this node) and serves
it as a listening node (`firmware_sim.serving.listen.listen`), its PBOs off until the manager
starts them. A scenario that kills this robot's node has it send itself SIGKILL at the outage's
time on the node's clock: after the first job at or past that time, in lock-step time within the
same quantum on every run; a node started again after the kill (the launcher gives it no
``--kill-at``) lives on.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Mapping
from pathlib import Path

from application.declaration import Application
from application.hardware import fabric_ports, live_natives
from application.plant import Setting
from application.prepared import database_of
from application.scenario import Scenario
from firmware_sim.core.node import Node
from firmware_sim.serving.listen import ListenConfig, listen


class NodeClock:
    """The node's clock for its firmware's devices, once the node is made."""

    def __init__(self) -> None:
        self.node: Node | None = None

    def __call__(self) -> float:
        return 0.0 if self.node is None else self.node.kernel.now

    def horizon(self) -> float:
        """The time the node's run under way goes to (`Node.horizon`)."""
        return 0.0 if self.node is None else self.node.horizon


def serve_node(
    application: Application,
    scenario: Scenario,
    robot: str,
    url: str,
    say: Callable[[str], None],
    *,
    lock_step: bool = False,
    flash: Path | None = None,
    kill_at: float | None = None,
    devices: Mapping[str, str] | None = None,
) -> int:
    """Make `robot`'s node and serve it on `url` until interrupted, its flash in `flash` (a
    file that outlives the process; None: in memory only); the exit status."""
    database = database_of(application, scenario)
    clock = NodeClock()
    plant = application.plant(
        Setting(
            application,
            scenario,
            database,
            clock,
            robot=robot,
            devices=dict(devices or {}),
            horizon=clock.horizon,
        )
    )
    try:
        ports = fabric_ports(database, [robot])
        codes = plant.firmware(robot) | {
            key.partition("@")[0]: code
            for key, code in live_natives(application, database, ports).items()
        }
        config = ListenConfig(
            listen=url,
            name=robot,
            natives=tuple(codes),
            switch_on=False,
            lock_step=lock_step,
            budget=application.budget,
            flash=flash,
        )

        def started(node: Node) -> None:
            clock.node = node
            if kill_at is not None:
                node.kernel.observe(_killer(kill_at))

        return listen(config, say, firmware=codes, started=started, port=ports.get(robot))
    finally:
        plant.close()


def _killer(at: float) -> Callable[[str, float], None]:
    """A kernel observer that ends this process on SIGKILL after the first job at or past `at`
    seconds of the node's clock."""

    def kill(_pbo: str, time: float) -> None:
        if time >= at - 1e-9:
            os.kill(os.getpid(), signal.SIGKILL)

    return kill
