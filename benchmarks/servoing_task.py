"""The visual-servoing task's own speed: frames per second of the whole task, with and without
the Dehazer running as guest code, against the camera's 30 frames per second.

The task runs as in the experiment (python -m visual_servoing): two emulated robots advancing
together in 1 ms steps, CamReader rendering the scene, SSD matching, TrajGen, HexMan driving six
CAN servo nodes over a virtual bus, the evaluators reporting; in the second configuration the
Dehazer's guest image (RV32IM on Unicorn) cleans every frame between CamReader and SSD. Each
configuration runs `--seconds` of virtual time after a second of warm-up; the figure is camera
frames per second of real time. The task can run in real time when it is at least 30.

    python benchmarks/servoing_task.py [--seconds S]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from refresh.configuration import Configuration, initial_configuration
from visual_servoing.dehazer_guest import NAME
from visual_servoing.experiment.experiment import FRAME, Experiment
from visual_servoing.experiment.scenarios import Scenario

GOAL = 30.0
CLEAN = Scenario("clean", "no fault", "nothing happens", faults={})


def with_dehazer(experiment: Experiment) -> Configuration:
    """The paper's chosen configuration: CamReader + Dehazer in the camera slot."""
    current = initial_configuration(experiment.loaded.task, experiment.loaded.database)
    database = experiment.loaded.database
    chain = (*current.chains[0], *database.placements_of(NAME))
    return current.replace(0, chain)


def frames_per_second(dehazed: bool, seconds: float) -> tuple[str, float]:
    """Real-time frames per second of the task in one configuration."""
    with tempfile.TemporaryDirectory() as work, Experiment(CLEAN, Path(work)) as experiment:
        target = (
            with_dehazer(experiment)
            if dehazed
            else initial_configuration(experiment.loaded.task, experiment.loaded.database)
        )
        experiment.deploy(target)
        experiment.run_for(1.0)
        start = time.perf_counter()
        experiment.run_for(seconds)
        elapsed = time.perf_counter() - start
    return target.label(), seconds / FRAME / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="virtual seconds measured")
    args = parser.parse_args()
    print(f"{'configuration':48}{'frames/s':>10}{'of 30 fps':>11}{'real time':>11}")
    for dehazed in (False, True):
        label, fps = frames_per_second(dehazed, args.seconds)
        print(f"{label:48}{fps:>10.1f}{fps / GOAL:>10.1f}x{'yes' if fps >= GOAL else 'NO':>11}")
    print(f"goal: the task with the Dehazer as guest code at >= {GOAL:g} frames/s (160 x 120)")


if __name__ == "__main__":
    main()
