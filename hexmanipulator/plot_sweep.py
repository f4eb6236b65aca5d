"""Plot the six servo angles and the platform yaw over a yaw sweep, run through the whole stack.

Example (the figure of docs/servos.md):
  python -m hexmanipulator.plot_sweep docs/img/hexman_sweep.png

A sweep PBO feeds a yaw of 20 degrees at 0.5 Hz into the HexMan PBO's yaw input; HexMan drives
six CAN servo nodes on an in-process virtual bus, all in virtual time on a pbort kernel. Each
cycle records the servo feedback, and the plate's yaw is recovered from it by the forward
kinematics, so the plot shows what the platform did, not what it was told.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import can
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from commandline import command_parser, entry_point, run
from commandline.arguments import input_file, output_file_ending
from commandline.output import save_figure
from hexmanipulator.can_bus import CanServoBus
from hexmanipulator.errors import HexmanipulatorError
from hexmanipulator.geometry import Geometry, load
from hexmanipulator.hexman_pbo import hexman_module
from hexmanipulator.kinematics import Pose, forward
from pbort import Kernel, NativeModule, NativePBO, PortIO, PortSpec
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.can_servo_server import CanServoServer

AMPLITUDE = 20.0
FREQUENCY = 0.5
SECONDS = 4.0
RATE = 50.0
GEOMETRY_MAX_BYTES = 1 << 20
"""A geometry file is a few hundred bytes: anything above a mebibyte is not one."""


class YawSweep(NativePBO):
    """A sine of yaw on output ``yaw`` (degrees)."""

    name = "sweep"
    ports = (PortSpec.output("yaw", dtype="<f8"),)

    def cycle(self, io: PortIO) -> None:
        io["yaw"] = AMPLITUDE * math.sin(2 * math.pi * FREQUENCY * io.now)


def sweep(geometry: Geometry) -> dict[str, np.ndarray]:
    """Run the sweep; per cycle: time, commanded yaw, servo feedback (6) and the plate's yaw."""
    kernel = Kernel()
    nodes = CanServoNodes(volts=geometry.supply_volts, now=kernel.clock.now)
    server = CanServoServer(nodes, can.Bus(interface="virtual", channel="hexman-sweep"))
    host = can.Bus(interface="virtual", channel="hexman-sweep")
    rows: list[list[float]] = []
    try:
        kernel.add(NativeModule(YawSweep), frequency=RATE, priority=0)
        kernel.add(hexman_module(CanServoBus(host, geometry), geometry), frequency=RATE, priority=1)
        kernel.connect("sweep.yaw", "hexman.yaw")
        for name in ("sweep", "hexman"):
            kernel.spawn(name)
            kernel.on(name)
        plate = Pose()
        while kernel.now < SECONDS:
            kernel.run(cycles=2)
            feedback = np.array(kernel.value("hexman.feedback"))
            plate = forward(geometry, feedback, guess=plate)
            rows.append([kernel.now, kernel.value("sweep.yaw"), *feedback, plate.yaw])
    finally:
        kernel.close()
        host.shutdown()
        server.close()
    table = np.array(rows)
    return {"t": table[:, 0], "command": table[:, 1], "servos": table[:, 2:8], "yaw": table[:, 8]}


def plot(data: dict[str, np.ndarray], out: Path) -> None:
    """Two panels: the six crank angles, and the commanded and achieved plate yaw."""
    figure, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6), dpi=100)
    for leg in range(6):
        top.plot(data["t"], data["servos"][:, leg], label=f"servo {leg}")
    top.set_ylabel("crank angle (deg)")
    top.legend(ncol=3, fontsize="small")
    top.grid(alpha=0.3)
    bottom.plot(data["t"], data["command"], "--", label="commanded yaw")
    bottom.plot(data["t"], data["yaw"], label="plate yaw (forward kinematics of feedback)")
    bottom.set_xlabel("time (s, virtual)")
    bottom.set_ylabel("yaw (deg)")
    bottom.legend(fontsize="small")
    bottom.grid(alpha=0.3)
    figure.suptitle(
        f"HexManipulator yaw sweep: +-{AMPLITUDE:g} deg at {FREQUENCY:g} Hz, CAN servos"
    )
    figure.tight_layout()
    save_figure(figure, out, metadata={"Software": None})
    plt.close(figure)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), HexmanipulatorError, argv)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser: one PNG file to write."""
    top = command_parser("python -m hexmanipulator.plot_sweep", __doc__)
    top.add_argument(
        "out", type=output_file_ending(".png"), metavar="OUT.png", help="the PNG file to write"
    )
    top.add_argument(
        "--geometry",
        type=input_file(GEOMETRY_MAX_BYTES),
        metavar="FILE.toml",
        help="a geometry file (default: the shipped hexmanipulator/hexman.toml)",
    )
    top.set_defaults(func=_draw)
    return top


def _draw(args: argparse.Namespace) -> None:
    plot(sweep(load(args.geometry)), args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with entry_point():
        sys.exit(main())
