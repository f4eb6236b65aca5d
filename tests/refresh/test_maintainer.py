"""The Maintainer's plans, applied to an in-memory model and to emulated nodes that receive real
module images over hexmigrate's transfer protocol."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from pbort import NativeModule, State
from pbort.errors import MethodFailedError
from refresh.appliers.in_memory import MemoryApplier
from refresh.appliers.in_process import NodeApplier
from refresh.configuration import Configuration, initial_configuration, parse_placement
from refresh.errors import ApplyError
from refresh.events import EventLog
from refresh.load import Loaded, loads
from refresh.maintainer import Maintainer, plan

DATABASE = """
[robots.a]
resources.power = { capacity = 100 }
[robots.b]
resources.power = { capacity = 100 }

[schemas.source]
kind = "sensor"
[schemas.source.modules.signal]
robots = ["a", "b"]
outputs = { y = "q16" }
needs = { power = 1 }
source = "native"
frequency = 100
constants = { shape = 0, amplitude = 3 }

[schemas.filter]
kind = "computation"
[schemas.filter.modules.gain]
robots = ["a", "b"]
inputs = { x = "q16" }
outputs = { y = "q16" }
needs = { power = 2 }
source = { image = "gain.hex" }
frequency = 100
constants = { k = 131072 }
[schemas.filter.modules.moving_average]
robots = ["b"]
inputs = { x = "q16" }
outputs = { y = "q16" }
needs = { power = 2 }
source = { image = "moving_average.hex" }
frequency = 100

[task]
name = "filtering"
robot = "a"
states = ["run"]
schemas = ["source", "filter"]
initial = ["signal", "gain"]
"""


@pytest.fixture
def loaded(tmp_path: Path, example_builds) -> Loaded:
    for name in ("gain", "moving_average"):
        image_from_elf(example_builds[name].elf).write(tmp_path / f"{name}.hex")
    return loads(DATABASE, "filtering.toml", tmp_path)


def configuration(loaded: Loaded, *modules: str) -> Configuration:
    chains = tuple((parse_placement(m, "a", loaded.database),) for m in modules)
    return Configuration(loaded.task.schemas, chains)


def test_a_deploy_plan_migrates_images_before_starting_them():
    loaded = loads(DATABASE)
    steps = plan(None, initial_configuration(loaded.task, loaded.database), loaded.database)
    assert [str(s) for s in steps.steps] == [
        "migrate gain to a",
        "start signal on a",
        "start gain on a",
        "connect signal.y@a -> gain.x@a",
    ]


def test_an_unchanged_configuration_needs_no_step():
    loaded = loads(DATABASE)
    current = initial_configuration(loaded.task, loaded.database)
    assert plan(current, current, loaded.database).steps == ()
    assert str(plan(current, current, loaded.database)) == "(no change)"


def test_replacing_a_module_keeps_the_rest_running():
    loaded = loads(DATABASE)
    current = configuration(loaded, "signal@b", "gain@b")
    target = configuration(loaded, "signal@b", "moving_average@b")
    applier = MemoryApplier(["a", "b"])
    maintainer = Maintainer(loaded.database, applier, EventLog())
    maintainer.apply(maintainer.plan(None, current))
    applier.applied.clear()
    maintainer.apply(maintainer.plan(current, target))
    assert applier.applied == [
        "migrate moving_average@b",
        "stop gain@b",
        "start moving_average@b",
        "connect signal.y@b -> moving_average.x@b",
    ]
    assert applier.robot("b").running == {"signal": "signal", "moving_average": "moving_average"}
    assert applier.robot("b").wiring == {"moving_average.x": ("signal.y", "b")}


def test_a_coalition_wires_across_robots_in_the_model():
    loaded = loads(DATABASE)
    target = configuration(loaded, "signal@a", "moving_average@b")
    applier = MemoryApplier(["a", "b"])
    Maintainer(loaded.database, applier, EventLog()).apply(plan(None, target, loaded.database))
    assert applier.robot("b").wiring == {"moving_average.x": ("signal.y", "a")}


def test_the_memory_applier_refuses_what_a_node_would():
    loaded = loads(DATABASE)
    applier = MemoryApplier(["a", "b"])
    with pytest.raises(ApplyError, match="expected image 'gain' installed, got none"):
        applier.start("a", "gain", loaded.database.module("gain"))
    with pytest.raises(ApplyError, match="expected a running PBO, got none"):
        applier.stop("a", "gain")


def test_plans_migrate_real_images_to_emulated_nodes(loaded: Loaded):
    database = loaded.database
    current = initial_configuration(loaded.task, database)
    moved = configuration(loaded, "signal@b", "moving_average@b")
    log = EventLog()
    with Node("a") as node_a, Node("b") as node_b:
        applier = NodeApplier({"a": node_a, "b": node_b}, natives={"signal": NativeModule(Signal)})
        maintainer = Maintainer(database, applier, log)
        maintainer.apply(maintainer.plan(None, current))
        assert set(node_a.modules) == {"gain"}
        node_a.run(until=0.1)
        assert node_a.kernel.value("gain.y") == 2 * node_a.kernel.value("gain.x") != 0

        timings = maintainer.apply(maintainer.plan(current, moved))
        assert [t.step.action for t in timings] == [
            "migrate",
            "stop",
            "stop",
            "start",
            "start",
            "connect",
        ]
        assert node_a.kernel.names == ()
        assert set(node_b.modules) == {"moving_average"}
        assert node_b.kernel.state("moving_average") is State.ON
        node_b.run(until=0.1)
        assert node_b.kernel.value("moving_average.y") != 0
        assert node_b.kernel.connections() == [("signal.y", "moving_average.x")]
    migrate = next(t for t in timings if t.step.action == "migrate")
    assert migrate.seconds > 0
    steps = log.of_kind("step")
    assert steps[-6].data["step"] == "migrate moving_average to b"
    assert log.of_kind("applied")[-1].data["seconds"] == pytest.approx(
        sum(t.seconds for t in timings)
    )


def test_a_plan_switches_away_from_a_pbo_that_faulted_into_error(loaded: Loaded):
    """A module that failed is in ERROR; the stop step takes it out all the same (the node
    kills it from ERROR as from OFF) and says so on its line."""
    current = initial_configuration(loaded.task, loaded.database)
    moved = Configuration(
        loaded.task.schemas,
        (
            (parse_placement("signal@b", "a", loaded.database),),
            (parse_placement("gain", "a", loaded.database),),
        ),
    )
    log = EventLog()
    with Node("a") as node_a, Node("b") as node_b:
        applier = NodeApplier({"a": node_a, "b": node_b}, natives={"signal": NativeModule(Signal)})
        maintainer = Maintainer(loaded.database, applier, log)
        maintainer.apply(maintainer.plan(None, current))
        node_a.kernel.off("signal")
        node_a.kernel.configure("signal.shape", 7)  # which its on() refuses: it fails
        with pytest.raises(MethodFailedError):
            node_a.kernel.on("signal")
        assert node_a.kernel.state("signal") is State.ERROR

        maintainer.apply(maintainer.plan(current, moved))
        assert node_a.kernel.names == ("gain", "bridge0_rx")
        assert node_b.kernel.state("signal") is State.ON
    stop = next(e for e in log.of_kind("step") if e.data["action"] == "stop")
    assert stop.data["note"] == "it was in ERROR: killed and removed"


def run_in_step(nodes: list[Node], seconds: float, step: float = 0.005) -> None:
    t = nodes[0].kernel.now
    while t < seconds - 1e-12:
        t += step
        for node in nodes:
            node.run(until=t)


def test_a_coalition_carries_the_port_between_nodes_over_a_bridge(loaded: Loaded):
    coalition = configuration(loaded, "signal@a", "gain@b")
    with Node("a") as node_a, Node("b") as node_b:
        applier = NodeApplier({"a": node_a, "b": node_b}, natives={"signal": NativeModule(Signal)})
        maintainer = Maintainer(loaded.database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, coalition))
        assert node_a.kernel.names == ("signal", "bridge0_tx")
        assert node_b.kernel.names == ("gain", "bridge0_rx")
        run_in_step([node_a, node_b], 0.2)
        # The ramp's value read at one period reaches gain at the next (115200 baud: 0.9 ms).
        sent, doubled = node_a.kernel.value("signal.y"), node_b.kernel.value("gain.y")
        assert doubled == 2 * (sent - 3) > 0
        bridge = applier.port_bridges[applier.bridges["b", "gain.x"].number]
        assert bridge.stats.skipped == 0 and bridge.stats.latency == pytest.approx(100 / 115200)

        back = configuration(loaded, "signal@a", "gain@a")
        maintainer.apply(maintainer.plan(coalition, back))
        assert node_a.kernel.names == ("signal", "gain")  # the bridge went with gain@b
        assert node_b.kernel.names == ()
        assert applier.bridges == {}


def test_an_image_that_went_missing_fails_its_migration_naming_the_module(tmp_path: Path):
    loaded = loads(DATABASE, "filtering.toml", tmp_path)  # no HEX file written
    with Node("a") as node_a, Node("b") as node_b:
        applier = NodeApplier({"a": node_a, "b": node_b}, natives={"signal": NativeModule(Signal)})
        gain = loaded.database.module("gain")
        with pytest.raises(ApplyError, match=f"migrate gain: .*{tmp_path / 'gain.hex'}"):
            applier.migrate("a", gain)


class Answering(MemoryApplier):
    """A model of the robots whose nodes answer reads with `values`, as a node might."""

    def __init__(self, values: list[object]) -> None:
        super().__init__(["a"])
        self.values = values

    def _read(self, robot: str, ports: tuple[str, ...]) -> list[object]:
        return self.values


@pytest.mark.parametrize("value", [10**400, "ten", None])
def test_a_read_that_is_no_float_is_an_error_naming_the_port(value) -> None:
    """An integer beyond a float's range is as refused as a text: no OverflowError escapes."""
    with pytest.raises(ApplyError, match=r"^read gain\.y on a: expected a scalar value, got "):
        Answering([1, value]).reads("a", ["gain.x", "gain.y"])
    assert Answering([1, 2.5]).reads("a", ["gain.x", "gain.y"]) == [1.0, 2.5]
