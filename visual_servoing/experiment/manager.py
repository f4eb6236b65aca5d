"""The experiment's manager in its own process: ``python -m visual_servoing manager --scenario
NAME --out DIR --node ROBOT=URL ... --servos URL --servos URL [--servo-control URL]
[--quantum S]``.

It opens the robots' nodes (``python -m visual_servoing node``) over their links, the servo
emulator's control link (lock-step time; without one, real time) and its own connections to the
two CAN buses to the servos, then runs the scenario as in process (`LinkedExperiment`) and writes
the same report, timeline and plot into DIR. A scenario that cuts a node's link reaches that
node through a `Relay` it can cut.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from pathlib import Path
from urllib.parse import urlsplit

from hexmanipulator.geometry import load as load_geometry
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.experiment import ROBOT_LINK_BAUD, Outcome
from visual_servoing.experiment.firmware import MANIPULATORS
from visual_servoing.experiment.linked import (
    QUANTUM,
    REPORT_PERIOD,
    LinkedApplier,
    LinkedExperiment,
    LinkedWorld,
)
from visual_servoing.experiment.relay import Relay
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
        relays = _relays(scenario, nodes, stack)
        reached = {
            robot: relays[robot].url if robot in relays else url for robot, url in nodes.items()
        }
        applier = LinkedApplier.open(
            reached, wire=BRIDGE_WIRE, rate=ROBOT_LINK_BAUD, period=REPORT_PERIOD
        )
        applier.relays = relays
        applier.down = set()
        try:
            world = LinkedWorld(applier, load_geometry(None), links, servos, quantum)
        except BaseException:
            applier.close()
            raise
        with LinkedExperiment(scenario, out, world) as experiment:
            outcome = experiment.run(progress)
    return outcome


def _relays(
    scenario: Scenario, nodes: Mapping[str, str], stack: contextlib.ExitStack
) -> dict[str, Relay]:
    """A relay to the node whose link `scenario` cuts (closed with `stack`), by robot."""
    outage = scenario.outage
    if outage is None or outage.kind != "cut":
        return {}
    parts = urlsplit(nodes[outage.robot])
    if parts.scheme != "socket" or parts.hostname is None or parts.port is None:
        raise ExperimentError(
            f"scenario {scenario.name}: expected robot {outage.robot}'s node on a "
            f"socket://HOST:PORT URL, to cut its link, got {nodes[outage.robot]}"
        )
    relay = Relay(parts.hostname, parts.port)
    stack.callback(relay.close)
    return {outage.robot: relay}
