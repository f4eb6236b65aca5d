"""The robots' FPGA fabrics in an application's runs: a reconfiguration port per robot whose
database entry has a fabric, and the E-PBOs of the hardware modules on them.

A hardware module's E-PBO only moves its data through the fabric (`firmware_sim.core.fabric_pbo`);
its ports are the application's (`Application.hardware`: a frame, an int32 offset), the rest is
the database's (`refresh.hardware`). Wherever a robot's node runs (in this process or its own),
its fabric is a port opened for the robot's fabric (`fabric_ports`) and the node's hardware
E-PBOs stream through it (`live_natives`); the manager's estimators run each one in shadow on a
model of its robot's fabric with the module's bitstreams (`estimator_natives`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from application.declaration import Application
from firmware_sim.core.fpga_port import DEFAULT_MODEL, ReconfigurationPort, open_port
from pbort.code import ModuleCode
from refresh.database import ModuleDatabase
from refresh.hardware import host_codes, node_codes


def fabric_ports(
    database: ModuleDatabase, robots: Iterable[str], model: str = DEFAULT_MODEL
) -> dict[str, ReconfigurationPort]:
    """A reconfiguration port on `model` for each of `robots` that has a fabric, by robot."""
    ports: dict[str, ReconfigurationPort] = {}
    for name in robots:
        fabric = database.robots[name].fabric
        if fabric is not None:
            ports[name] = open_port(fabric.spec, model, fabric.width)
    return ports


def live_natives(
    application: Application,
    database: ModuleDatabase,
    ports: Mapping[str, ReconfigurationPort],
) -> dict[str, ModuleCode]:
    """The hardware E-PBOs of each robot of `ports`, streaming through its port, by
    ``Module@robot``."""
    codes: dict[str, ModuleCode] = {}
    for robot, port in ports.items():
        codes |= node_codes(database, robot, port, application.hardware)
    return codes


def estimator_natives(application: Application, database: ModuleDatabase) -> dict[str, ModuleCode]:
    """The hardware E-PBOs the manager's estimators run, each in shadow on a model of its
    robot's fabric, by ``Module@robot``."""
    return host_codes(database, application.hardware)
