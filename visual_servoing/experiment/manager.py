"""The experiment's manager in its own process: ``python -m visual_servoing manager --scenario
NAME --out DIR --node ROBOT=URL ... --servos URL --servos URL [--servo-control URL]
[--quantum S]``.

It opens the robots' nodes (``python -m visual_servoing node``) over their links, the servo
emulator's control link (lock-step time; without one, real time) and its own connections to the
two CAN buses to the servos, then runs the scenario as in process (`LinkedExperiment`) and writes
the same report, timeline and plot into DIR.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from pathlib import Path

from hexmanipulator.geometry import load as load_geometry
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from visual_servoing.experiment.experiment import ROBOT_LINK_BAUD, Outcome
from visual_servoing.experiment.firmware import MANIPULATORS
from visual_servoing.experiment.linked import (
    QUANTUM,
    REPORT_PERIOD,
    LinkedApplier,
    LinkedExperiment,
    LinkedWorld,
)
from visual_servoing.experiment.scenarios import Scenario

BRIDGE_WIRE = "serial"
"""What a bridge between the robots models in virtual time (it crosses TCP): the in-process
experiment's 12 Mbaud serial link."""


def run_manager(
    scenario: Scenario,
    out: Path,
    nodes: Mapping[str, str],
    buses: tuple[str, ...],
    servo_control: str | None,
    quantum: float = QUANTUM,
    progress: Callable[[float], None] | None = None,
) -> Outcome:
    """Run `scenario` on the nodes at `nodes` (robot -> URL) with the servos on `buses` (the
    URLs of ``can1`` and ``can2``), in lock-step time through `servo_control` (the servo
    emulator's control URL), or in real time when it is None. The Dehazer is built into `out`."""
    links = dict(zip((link for _name, link in MANIPULATORS), buses, strict=True))
    with contextlib.ExitStack() as stack:
        servos = None
        if servo_control is not None:
            link = stack.enter_context(open_link(servo_control))
            servos = NodeControl(Sender(link))
        applier = LinkedApplier.open(
            nodes, wire=BRIDGE_WIRE, rate=ROBOT_LINK_BAUD, period=REPORT_PERIOD
        )
        try:
            world = LinkedWorld(applier, load_geometry(None), links, servos, quantum)
        except BaseException:
            applier.close()
            raise
        with LinkedExperiment(scenario, out, world) as experiment:
            outcome = experiment.run(progress)
    return outcome
