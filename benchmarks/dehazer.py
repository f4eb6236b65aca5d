"""The Dehazer's speed: the guest module on an emulated node against numpy and OpenCV.

Prints, for 160 x 120 frames of the camera scene with salt-and-pepper noise and fog:
- the scene's render time per frame;
- the guest Dehazer on a Node, frames per second in real time, per frame as the kernel runs it
  (a native frame player, the port copies into and out of the Dehazer's area, the cycle and the
  evaluator with its four ecalls); then where that time goes: the guest cycle alone, the
  copies of the instance area into the task window and back, the port put and get;
- guest instructions per frame and the virtual time they take at the node's clock;
- in the same process, the numpy reference (the same algorithm, byte for byte) and OpenCV's
  medianBlur + min-max normalize (a similar filter, not the same stretch) in frames per second;
- the Dehazer in hardware (the experiment's fabric: the streaming 3x3 median and the contrast
  stretch in Verilog, `visual_servoing/experiment/hardware.toml`): fabric cycles per frame and
  their time at the fabric's 100 MHz, and the host time per frame on the Verilog (Verilator)
  and on the transaction-level model; whether its frames are the numpy reference's (the
  stretch takes its percentiles from the frame before);
- the repair's migration: the guest Dehazer's image against the hardware Dehazer's two partial
  bitstreams over a modelled 115200 baud serial line, plus the fabric's reconfiguration cycles.

The goal: at least 200 frames per second with the Dehazer running as guest code (the first
goal was 30).

    python benchmarks/dehazer.py [--quick]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from firmware_sim.core.guest import CONTEXT_SIZE
from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.wires.transfer import run_transfer
from hexmigrate.image import ModuleImage
from morphing_crossbar.hex_image import configuration_cycles
from morphing_crossbar.reconfiguration_port import crossbar_port
from pbort.code import Method, Role, Services
from refresh.hardware import bitstream_images, scratch_port
from refresh.load import load
from visual_servoing.dehaze import dehaze, median3x3, percentiles, stretch_table
from visual_servoing.dehazer_guest import (
    INPUT_PORT,
    INSTRUCTION_BUDGET,
    NAME,
    OUTPUT_PORT,
    dehazer_image,
)
from visual_servoing.experiment.scenarios import HARDWARE
from visual_servoing.frame_player import frame_player
from visual_servoing.image_faults import FaultSchedule
from visual_servoing.scene import Scene

RATE = 30.0  # frames per second the task needs
GOAL = 200.0
FABRIC_HZ = 100e6
HARDWARE_DATABASE = load(HARDWARE).database
FABRIC = HARDWARE_DATABASE.robots["hexman"].fabric
BITSTREAMS = bitstream_images(HARDWARE_DATABASE.module("Dehazer_hw"))


def per_call(action: Callable[[], object], count: int) -> float:
    """Seconds per call of `action`, best of three runs of `count` calls."""
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(count):
            action()
        best = min(best, (time.perf_counter() - start) / count)
    return best


def faulty_frames(scene: Scene, count: int) -> list[np.ndarray]:
    """`count` views of a yaw sweep through salt-and-pepper noise and fog."""
    schedule = FaultSchedule(seed=1)
    schedule.add("fog", 0.7)
    schedule.add("salt_pepper", 0.1)
    yaws = np.linspace(-20.0, 20.0, count)
    return [schedule.apply(scene.render(yaw), index / RATE) for index, yaw in enumerate(yaws)]


def guest_figures(frames: list[np.ndarray], builds: Path, count: int) -> dict[str, float]:
    """Seconds per frame of the kernel job and of its parts; instructions and virtual seconds."""
    with Node(config=NodeConfig(budget=INSTRUCTION_BUDGET)) as node:
        node.load(dehazer_image(builds))
        node.start(frame_player(frames), RATE, priority=0)
        node.start(NAME, RATE, priority=1)
        node.kernel.connect(f"player.{OUTPUT_PORT}", f"{NAME}.{INPUT_PORT}")
        job = per_call(lambda: node.run(cycles=2), count)
        stats = node.kernel.stats(NAME)
        # An executor: an estimator's repeated calls on one frame would be replayed, not run.
        instance = node.modules[NAME].code.instantiate(
            Role.EXECUTOR, Services(report=lambda *_: None, now=lambda: 0.0, log=lambda _: None)
        )
        try:
            instance.put(INPUT_PORT, frames[0])
            cycle = per_call(lambda: instance.call(Method.CYCLE), count)
            ports = per_call(
                lambda: (instance.put(INPUT_PORT, frames[0]), instance.get(OUTPUT_PORT)), count
            )
            body = instance.module.layout.size - CONTEXT_SIZE
            copy = per_call(lambda: node.cpu.copy(instance.window, instance.area, body), count)
        finally:
            instance.release()
    return {
        "job": job,
        "cycle": cycle,
        "ports": ports,
        "copies": 2 * copy,
        "area": body,
        "instructions": stats.instructions / stats.cycles,
        "virtual": stats.busy_time / stats.cycles,
    }


def hardware_figures(frames: list[np.ndarray], model: str) -> dict[str, float]:
    """The hardware Dehazer's fabric on `model`: host seconds per frame, fabric cycles per
    frame (RTL only), and how many frames after the first equal the numpy reference's."""
    port = crossbar_port(FABRIC.spec, model, FABRIC.width)
    for image in BITSTREAMS:
        port.load(image)
    outputs: list[np.ndarray] = []

    def frame_through(frame: np.ndarray) -> None:
        (pixels,) = port.stream({0: frame.ravel().tolist()}).values()
        outputs.append(np.asarray(pixels, dtype=np.uint8).reshape(frame.shape))

    start_cycles = port.model.cycles if model == "rtl" else 0
    start = time.perf_counter()
    for frame in frames:
        frame_through(frame)
    seconds = (time.perf_counter() - start) / len(frames)
    cycles = (port.model.cycles - start_cycles) / len(frames) if model == "rtl" else 0.0
    same = sum(
        np.array_equal(out, _stretched_by(frames[k - 1], frames[k]))
        for k, out in enumerate(outputs)
        if k
    )
    return {"seconds": seconds, "cycles": cycles, "same": same}


def _stretched_by(before: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """The reference of the hardware Dehazer: `frame`'s median, stretched by the percentiles of
    the median of the frame `before` (a streaming stretch knows a frame's levels at its end)."""
    low, high = percentiles(median3x3(before))
    return stretch_table(low, high)[median3x3(frame)]


def migration_figures(guest: ModuleImage) -> dict[str, float]:
    """Seconds on a modelled 115200 baud serial line: the guest Dehazer's image, and the
    hardware Dehazer's bitstreams (each to a node with a fabric, as the experiment's)."""
    software = run_transfer(guest, "serial")
    hardware = 0.0
    for image in BITSTREAMS:
        with Node("fpga", fpga=scratch_port(image)) as node:
            hardware += run_transfer(image, "serial", node=node).seconds
    return {
        "software": software.seconds,
        "software_bytes": guest.size,
        "hardware": hardware,
        "hardware_bytes": sum(image.size for image in BITSTREAMS),
        "cycles": sum(configuration_cycles(image) for image in BITSTREAMS),
    }


def normalize_with_opencv(frame: np.ndarray) -> np.ndarray:
    """OpenCV's nearest one-liner: 3x3 median, then min-max stretch (no percentiles)."""
    median = cv2.medianBlur(frame, 3)
    return cv2.normalize(median, None, 0, 255, cv2.NORM_MINMAX)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer frames (for CI)")
    args = parser.parse_args()
    count = 15 if args.quick else 60

    scene = Scene()
    render = per_call(lambda: scene.render(7.5), 20 * count)
    print(f"scene: {scene.width} x {scene.height}, render {render * 1e6:.1f} µs per frame")
    frames = faulty_frames(scene, count)

    with tempfile.TemporaryDirectory() as builds:
        guest = guest_figures(frames, Path(builds), count)
        image = dehazer_image(Path(builds))
    fps = 1.0 / guest["job"]
    print(
        f"guest Dehazer on a node: {fps:.1f} frames/s ({guest['job'] * 1e3:.2f} ms per frame, "
        f"kernel job with ports and evaluator)  (goal: >= {GOAL:.0f} frames/s)"
    )
    print(
        f"  of which: guest cycle {guest['cycle'] * 1e3:.2f} ms, area copies to the task window "
        f"and back {guest['copies'] * 1e6:.1f} µs ({guest['area']} bytes each way), "
        f"port put + get {guest['ports'] * 1e6:.1f} µs"
    )
    print(
        f"  {guest['instructions'] / 1e6:.3f} M guest instructions per frame "
        f"({guest['instructions'] / frames[0].size:.1f} per pixel), "
        f"{guest['virtual'] * 1e3:.2f} ms of virtual time at 100 MHz"
    )
    reference = per_call(lambda: dehaze(frames[0]), count)
    opencv = per_call(lambda: normalize_with_opencv(frames[0]), 20 * count)
    print(
        f"numpy reference (same bytes): {1 / reference:.0f} frames/s; "
        f"OpenCV medianBlur + normalize: {1 / opencv:.0f} frames/s; "
        f"guest x{guest['job'] / reference:.1f} the numpy time"
    )
    for model in ("rtl", "tlm"):
        hardware = hardware_figures(frames, model)
        cycles = (
            f"{hardware['cycles']:,.0f} fabric cycles per frame "
            f"({hardware['cycles'] / FABRIC_HZ * 1e3:.2f} ms at 100 MHz), "
            if model == "rtl"
            else ""
        )
        print(
            f"hardware Dehazer on the fabric ({model}): {cycles}"
            f"{hardware['seconds'] * 1e3:.1f} ms of host time per frame; "
            f"{hardware['same']} of {len(frames) - 1} frames the numpy reference's "
            f"(the stretch by the frame before's levels)"
        )
    moved = migration_figures(image)
    print(
        f"repair over serial 115200: the guest Dehazer's image {moved['software_bytes']} B in "
        f"{moved['software']:.3f} s; the hardware Dehazer's bitstreams "
        f"{moved['hardware_bytes']} B in {moved['hardware']:.3f} s, then "
        f"{moved['cycles']} fabric cycles ({moved['cycles'] / FABRIC_HZ * 1e6:.2f} µs) to "
        f"reconfigure: x{moved['software'] / moved['hardware']:.0f} faster"
    )


if __name__ == "__main__":
    main()
