"""The visual-servoing task's own speed: frames per second of the whole task, with and without
the Dehazer running as guest code, against the camera's 30 frames per second.

The task runs as in the experiment (python -m visual_servoing run, in process): two emulated
robots advancing together in 1 ms steps, CamReader rendering the scene, SSD matching, TrajGen,
HexMan driving six CAN servo nodes over a virtual bus, the evaluators reporting, the world sampled
every frame; in the second configuration the Dehazer's guest image (RV32IM on Unicorn) cleans
every frame between CamReader and SSD. Each configuration is deployed by the Maintainer and runs
`--seconds` of virtual time after a second of warm-up; the figure is camera frames per second of
real time. The task can run in real time when it is at least 30.

    python benchmarks/servoing_task.py [--seconds S]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from application.runs import in_process
from application.scenario import Scenario
from refresh.configuration import Configuration, initial_configuration
from refresh.runtime import Runtime
from visual_servoing.declaration import APPLICATION, FRAME
from visual_servoing.dehazer_guest import NAME

GOAL = 30.0
CLEAN = Scenario("clean", "no fault", "nothing happens")


def configuration(runtime: Runtime, dehazed: bool) -> Configuration:
    """The task's initial configuration, or the paper's chosen one: CamReader + Dehazer in the
    camera slot."""
    current = initial_configuration(runtime.task, runtime.database)
    if not dehazed:
        return current
    chain = (*current.chains[0], *runtime.database.placements_of(NAME))
    return current.replace(0, chain)


def frames_per_second(dehazed: bool, seconds: float) -> tuple[str, float]:
    """Real-time frames per second of the task in one configuration."""
    with tempfile.TemporaryDirectory() as work, in_process(APPLICATION, CLEAN, Path(work)) as run:
        target = configuration(run.runtime, dehazed)
        maintainer = run.runtime.maintainer
        maintainer.apply(maintainer.plan(None, target))
        run.session.wait(1.0)
        start = time.perf_counter()
        run.session.wait(seconds)
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
