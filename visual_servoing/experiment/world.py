"""Two robots and what they act on, in one virtual time.

The HexManipulator robot and the rotation robot are two emulated nodes (`firmware_sim.Node`),
each with its kernel on a virtual clock; `advance` runs both in small steps to the same time, so
ports bridged between them (`firmware_sim.bridge`) arrive when the link delivers them. The
HexManipulator's six S3003 servos are CAN servo nodes (`servo_emulators`) stepping on the
same clock, each with two CAN interfaces on two in-process virtual buses, as redundant actuators
have: the HexMan PBO reaches them through `hexmanipulator.can_bus` on the first, HexMan_alt on
the second; the first bus's host controller can be cut off (`cut_servo_link`: it goes bus-off).
The cameras on the travelling plate look along the plate's yaw, which
the world recovers from the servos' feedback by the forward kinematics (`PlateTracker`, shared
with a HexManipulator node in its own process): what the platform did, not what it was told.
"""

from __future__ import annotations

import itertools
import os

import can
import numpy as np

from firmware_sim.core.node import Node, NodeConfig
from hexmanipulator.can_bus import CanServoBus
from hexmanipulator.geometry import Geometry
from hexmanipulator.kinematics import Pose
from pbort.errors import KernelError
from servo_emulators.bus_off import BusOffController
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.can_servo_server import CanServoServer
from visual_servoing.dehazer_guest import INSTRUCTION_BUDGET
from visual_servoing.experiment.plate import PlateTracker

ROBOTS = ("hexman", "rotation")
"""The robots' names: the task runs on the first."""
STEP = 0.001
"""Seconds of virtual time the two nodes advance together."""
SERVO_LINKS = ("can1", "can2")
"""The two CAN buses to the servo nodes."""
_CHANNELS = itertools.count()


class World:
    """The robots' nodes, the servos and the clock. `hexman` names the HexMan PBO whose
    ``feedback`` port gives the plate's pose."""

    def __init__(self, geometry: Geometry, hexman: str = "HexMan") -> None:
        self.geometry = geometry
        self.hexman = hexman
        self.time = 0.0
        config = NodeConfig(budget=INSTRUCTION_BUDGET)
        self.nodes = {robot: Node(robot, config) for robot in ROBOTS}
        self.servos = CanServoNodes(volts=geometry.supply_volts, now=self.now)
        self._servers: list[CanServoServer] = []
        self._hosts: dict[str, BusOffController] = {}
        self.servo_buses: dict[str, CanServoBus] = {}
        for link in SERVO_LINKS:
            channel = f"vs-{link}-{os.getpid()}-{next(_CHANNELS)}"
            bus = can.Bus(interface="virtual", channel=channel)
            self._servers.append(CanServoServer(self.servos, bus))  # the nodes lock themselves
            host = BusOffController(can.Bus(interface="virtual", channel=channel))
            self._hosts[link] = host
            self.servo_buses[link] = CanServoBus(host, geometry)
        self._plate = PlateTracker(geometry)

    def now(self) -> float:
        """The world's time in seconds."""
        return self.time

    def advance(self, seconds: float) -> None:
        """Run both robots `seconds` further, together."""
        end = self.time + seconds
        while self.time < end - 1e-12:
            self.time = min(end, self.time + STEP)
            for node in self.nodes.values():
                node.run(until=self.time)

    def plate(self) -> Pose:
        """The travelling plate's pose from the servos' latest feedback (home before any)."""
        node = self.nodes[ROBOTS[0]]
        try:
            feedback = np.asarray(node.kernel.value(f"{self.hexman}.feedback"), dtype=float)
        except KernelError:  # HexMan is not running: the plate stays where it was
            return self._plate.pose
        return self._plate.update(feedback)

    def follow(self, manipulator: str) -> None:
        """The plate's pose comes from PBO `manipulator`'s feedback from now on."""
        self.hexman = manipulator

    def cut_servo_link(self, link: str) -> None:
        """The host's controller on `link` leaves the bus (a cut or shorted cable)."""
        self._hosts[link].bus_off()

    def plate_yaw(self) -> float:
        """Where the cameras on the plate look, in degrees."""
        return float(self.plate().yaw)

    def close(self) -> None:
        """Stop the servos' server and the nodes."""
        for bus in self.servo_buses.values():
            bus.close()
        for server in self._servers:
            server.close()
        for host in self._hosts.values():
            host.shutdown()
        for node in self.nodes.values():
            node.close()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
