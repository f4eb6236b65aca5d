"""The whole ReFrESH loop on a pbort kernel with native E-PBOs of the paper's scenario: the Decider
reads the evaluators' buffers and declares the injected camera noise after its debounce, the
Locator and Generator estimate in shadow runs, and the Maintainer applies the choice on an emulated
node, after which the Decider sees the task satisfied again."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.core.node import Node
from pbort import Kernel, NativeModule, NativePBO, PerformanceKind, PortIO, PortSpec
from refresh.adaptation import decide
from refresh.appliers.in_process import NodeApplier
from refresh.configuration import initial_configuration
from refresh.decider import Decider
from refresh.estimators.kernel import KernelEstimator
from refresh.events import EventLog
from refresh.load import load
from refresh.maintainer import Maintainer
from refresh.performance import assess, usage

DATABASE = Path(__file__).parents[2] / "refresh" / "data" / "visual_servoing.toml"
F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL
TARGET_OFFSET = 10.0  # pixels between the target and the image centre, seen without noise


def flow(
    name: str,
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    power: float,
    constants: tuple[str, ...] = (),
):
    """A native E-PBO class whose cycle and estimate run `transform` on its float ports, and whose
    evaluator reports its power (non-functional 0)."""

    class Pbo(NativePBO):
        ports = (
            *(PortSpec.input(p, dtype="<f8") for p in inputs),
            *(PortSpec.output(p, dtype="<f8") for p in outputs),
            *(PortSpec.const(p, dtype="<f8") for p in constants),
        )

        def cycle(self, io: PortIO) -> None:
            self.transform(io)

        def estimate(self, io: PortIO) -> None:
            self.transform(io)
            self.report(io)

        def evaluate(self, io: PortIO) -> None:
            io.report(NF, 0, power)
            self.report(io)

        def transform(self, io: PortIO) -> None:
            raise NotImplementedError

        def report(self, io: PortIO) -> None:
            """Functional reports: only TrajGen's (EV_diff) count for the task."""

    Pbo.name = name
    Pbo.__name__ = name
    return Pbo


class CamReader(flow("CamReader", (), ("image",), 2, constants=("noise",))):
    """The image, reduced to where the target appears: its offset plus the camera's noise."""

    def transform(self, io):
        io["image"] = TARGET_OFFSET + io["noise"]


class CamReaderAlt(flow("CamReader_alt", (), ("image",), 6)):
    def transform(self, io):
        io["image"] = TARGET_OFFSET


class Dehazer(flow("Dehazer", ("raw",), ("image",), 3)):
    """Noise cancellation: pulls the apparent position back towards the real offset."""

    def transform(self, io):
        io["image"] = TARGET_OFFSET + (io["raw"] - TARGET_OFFSET) * 0.1


def matcher(name: str, power: float):
    class Ssd(flow(name, ("image",), ("target",), power)):
        def transform(self, io):
            io["target"] = io["image"]

    return Ssd


def trajectory(name: str, power: float):
    class TrajGen(flow(name, ("target",), ("theta",), power)):
        def transform(self, io):
            io["theta"] = io["target"] * 0.01

        def report(self, io):
            io.report(F, 0, abs(io["target"]))

    return TrajGen


class HexMan(flow("HexMan", ("theta",), (), 3)):
    def transform(self, io):
        self.angle = io["theta"]


NATIVES = {
    cls.name: NativeModule(cls)
    for cls in (
        CamReader,
        CamReaderAlt,
        Dehazer,
        matcher("SSD", 3),
        matcher("SSD_alt", 4),
        trajectory("TrajGen", 2),
        trajectory("TrajGen_alt", 3),
        HexMan,
    )
}


@pytest.fixture
def loaded():
    return load(DATABASE)


def test_decider_waits_for_its_debounce_then_declares(loaded):
    database, task = loaded.database, loaded.task
    current = initial_configuration(task, database)
    log = EventLog()
    decider = Decider(task, database, log, debounce=3)
    with Kernel() as kernel:
        for placement in current.placements:
            kernel.add(NATIVES[placement.module], frequency=30)
        for source, sink in current.connections(database):
            kernel.connect(source, sink)
        for name in kernel.names:
            kernel.spawn(name)
            kernel.on(name)
        sources = {"hexmanipulator": kernel}
        kernel.run(until=0.2)
        assert decider.step(current, sources) is None
        assert decider.violations == 0

        kernel.off("CamReader")
        kernel.configure("CamReader.noise", 70.0)
        kernel.on("CamReader")
        detections = []
        for period in range(1, 4):
            kernel.run(until=0.2 + period * 0.1)
            detections.append(decider.step(current, sources))
    assert detections[:2] == [None, None]
    detection = detections[2]
    assert detection is not None and detection.periods == 3
    assert detection.assessment.values["diff"] == pytest.approx(80.0)
    assert detection.assessment.failing() == ["diff"]
    assert detection.assessment.usage["hexmanipulator", "power"] == 10.0
    assert [e.kind for e in log] == ["violation", "violation", "detection"]


def test_one_noisy_period_is_not_a_detection(loaded):
    decider = Decider(loaded.task, loaded.database, EventLog(), debounce=2)
    current = initial_configuration(loaded.task, loaded.database)
    bad = assess(usage(current, loaded.database), {"diff": 90.0}, loaded.task, loaded.database)
    good = assess(usage(current, loaded.database), {"diff": 9.0}, loaded.task, loaded.database)
    assert decider.judge(bad) is None
    assert decider.judge(good) is None
    assert decider.judge(bad) is None
    assert decider.judge(bad) is not None


def test_shadow_run_estimates_locate_and_choose_like_the_paper(loaded):
    database, task = loaded.database, loaded.task
    current = initial_configuration(task, database)
    with Kernel() as kernel:
        estimator = KernelEstimator(
            kernel, NATIVES, database, task, inputs={"CamReader.noise": 70.0}
        )
        log = EventLog()
        decision = decide(current, database, task, estimator, log)
    assert decision.location.module == "CamReader"
    assert decision.target.label() == "{CamReader, Dehazer, SSD, TrajGen, HexMan}"
    values = [a.values["diff"] for _, a in decision.choice.candidates]
    assert values == pytest.approx([10.0, 17.0, 10.0])


def test_the_loop_repairs_the_task_on_an_emulated_node(loaded):
    database, task = loaded.database, loaded.task
    current = initial_configuration(task, database)
    log = EventLog()
    with Node("hexmanipulator") as node:
        applier = NodeApplier({"hexmanipulator": node}, natives=NATIVES)
        maintainer = Maintainer(database, applier, log)
        maintainer.apply(maintainer.plan(None, current))
        node.kernel.off("CamReader")
        node.kernel.configure("CamReader.noise", 70.0)
        node.kernel.on("CamReader")
        sources = {"hexmanipulator": node.kernel}
        decider = Decider(task, database, log, debounce=2)
        detection = None
        while detection is None:
            node.run(until=node.kernel.now + 0.1)
            detection = decider.step(current, sources)
        estimator = KernelEstimator(
            node.kernel, NATIVES, database, task, inputs={"CamReader.noise": 70.0}
        )
        target = decide(current, database, task, estimator, log).target
        plan = maintainer.plan(current, target)
        assert [str(s) for s in plan.steps] == [
            "disconnect SSD.image@hexmanipulator",
            "start Dehazer on hexmanipulator",
            "connect CamReader.image@hexmanipulator -> Dehazer.raw@hexmanipulator",
            "connect Dehazer.image@hexmanipulator -> SSD.image@hexmanipulator",
        ]
        timings = maintainer.apply(plan)
        node.run(until=node.kernel.now + 0.2)
        assert decider.step(target, sources) is None
        latest = node.kernel.performance("TrajGen").latest(F, 0)
        assert latest.value == pytest.approx(17.0)
    assert len(timings) == 4 and all(t.seconds >= 0 for t in timings)
    kinds = [e.kind for e in log]
    for kind in ("detection", "test_case", "location", "candidate", "choice", "plan", "step"):
        assert kind in kinds
