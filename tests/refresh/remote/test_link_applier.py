"""The Maintainer's plan over links: real `firmware-sim listen` nodes in their own processes,
reached over TCP on loopback or a noisy pty, deployed by a `LinkApplier` (the image sent, the
rate and the constants set, the PBOs started and wired, bridges between nodes, in real or
lock-step time); the Decider then reads the nodes' pushed evaluator outputs through the
applier's sources. Refusals and dead or silent nodes end in a NodeLinkError that names the
robot and the URL, within the requests' bounded tries."""

from __future__ import annotations

import dataclasses
import re
import signal
import time
import zlib
from collections.abc import Callable, Iterator

import pytest

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links.free_port import free_port
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.time_master import TimeMaster
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric_spec import fabric_of
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.routing import through_route
from pbort.code import PerformanceKind
from refresh.appliers.base import Migration
from refresh.appliers.over_links import LinkApplier
from refresh.configuration import Configuration, initial_configuration, parse_placement
from refresh.decider import Decider
from refresh.errors import NodeLinkError
from refresh.events import EventLog
from refresh.images import migration_image
from refresh.load import Loaded, loads
from refresh.maintainer import Maintainer

DATABASE = """
[robots.a]
resources.power = { capacity = 100, reserve = 20, report = 0 }
[robots.b]
resources.power = { capacity = 100, reserve = 20, report = 0 }

[schemas.source]
kind = "sensor"
[schemas.source.modules.signal]
robots = ["a"]
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
frequency = 50
constants = { k = 131072 }
[schemas.filter.modules.moving_average]
robots = ["a"]
inputs = { x = "q16" }
outputs = { y = "q16" }
needs = { power = 2 }
source = { image = "moving_average.hex" }
frequency = 20

[task]
name = "filtering"
robot = "a"
states = ["run"]
schemas = ["source", "filter"]
initial = ["signal", "gain"]

[task.metrics.error]
schema = "filter"
index = 0
threshold = 1
direction = "at_most"
"""
NODE = ("--native", "signal", "--no-start")
"""A node of the database's robots: the native signal built in, every PBO waiting for the host."""
WAIT = 10.0
"""Seconds a test waits at most for what a node pushes or computes."""
QUICK = {"timeout": 0.3, "retries": 2}
"""Short waits for the tests whose node dies: a request fails within a second."""


@pytest.fixture(scope="module")
def loaded(example_builds, tmp_path_factory: pytest.TempPathFactory) -> Loaded:
    directory = tmp_path_factory.mktemp("remote")
    for name in ("gain", "moving_average"):
        image_from_elf(example_builds[name].elf).write(directory / f"{name}.hex")
    return loads(DATABASE, "filtering.toml", directory)


def configuration(loaded: Loaded, *modules: str) -> Configuration:
    chains = tuple((parse_placement(m, "a", loaded.database),) for m in modules)
    return Configuration(loaded.task.schemas, chains)


def wait_until(condition: Callable[[], object], what: str) -> None:
    """Return once `condition()` is true; fail after WAIT seconds."""
    deadline = time.monotonic() + WAIT
    while not condition():
        assert time.monotonic() < deadline, f"no {what} within {WAIT:g} s"
        time.sleep(0.02)


def listed(control: NodeControl) -> dict[str, tuple[str, float | None]]:
    """PBO -> (state, rate) as the node lists them."""
    return {row.name: (row.state, row.rate) for row in control.pbos()}


@pytest.fixture
def node_a() -> Iterator[NodeProcess]:
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--name", "a") as node:
        yield node


def test_a_plan_deploys_over_the_link_and_the_decider_reads_the_reports(loaded, node_a):
    database = loaded.database
    url = node_a.url
    current = initial_configuration(loaded.task, database)
    with LinkApplier.open({"a": url}) as applier:
        maintainer = Maintainer(database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, current))
        node = applier.node("a")
        assert listed(node.control) == {"signal": ("ON", 100.0), "gain": ("ON", 50.0)}
        source = applier.sources()["a"]
        gain = source.performance("gain")  # filled as the source polls the link
        wait_until(
            lambda: source.performance("gain").latest(PerformanceKind.NON_FUNCTIONAL, 0),
            "power report",
        )
        wait_until(lambda: applier.read("a", "gain.y") > 0, "gain output")
        ((_, x), (_, y)) = node.control.read(("gain.x", "gain.y"))
        # k = 131072 is 2.0 in Q16.16: y doubles a value of the ramp (steps of 3) that x,
        # fed at 100 Hz while gain runs at 50 Hz, has reached or passed.
        assert isinstance(y, int) and y % 6 == 0 and 0 < y <= 2 * x

        values, used = Decider(loaded.task, database, EventLog()).observe(
            current, applier.sources()
        )
        assert values == {"error": 0.0}  # |y - k x| is exact for a doubled ramp
        power = gain.latest(PerformanceKind.NON_FUNCTIONAL, 0)
        assert power is not None and used["a", "power"] == pytest.approx(1 + power.value)
        assert source.clock is not None and power.time <= source.clock
        assert source.leftover is not None and 0 < source.leftover < 100
        # The applier's requests came while the node pushed: not one push was lost.
        assert source.reports > 0 and source.missed == 0 and source.damaged == 0

        averaged = configuration(loaded, "signal", "moving_average")
        timings = maintainer.apply(maintainer.plan(current, averaged))
        assert [t.step.action for t in timings] == ["migrate", "stop", "start", "connect"]
        assert listed(node.control) == {
            "signal": ("ON", 100.0),
            "gain": ("OFF", 50.0),
            "moving_average": ("ON", 20.0),
        }
        assert applier.wires == {("a", "moving_average.x"): "signal.y"}
        assert len(source.performance("gain")) == 0  # an OFF PBO reports nothing
        wait_until(lambda: applier.read("a", "moving_average.y") > 0, "moving average")
        assert source.missed == 0

    # A second manager finds both images installed and sends neither again.
    with LinkApplier.open({"a": url}) as again:
        again.migrate("a", database.module("gain"))
        again.migrate("a", database.module("moving_average"))
    registered = [line for line in node_a.lines() if line.startswith("registered ")]
    assert [line.split()[1] for line in registered] == ["gain", "moving_average"]


def test_several_ports_are_read_in_one_request_at_one_moment(loaded, node_a):
    database = loaded.database
    current = initial_configuration(loaded.task, database)
    with LinkApplier.open({"a": node_a.url}) as applier:
        maintainer = Maintainer(database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, current))
        wait_until(lambda: applier.read("a", "gain.y") > 0, "gain output")
        control = applier.node("a").control
        requests: list[tuple[str, ...]] = []
        read = control.read

        def counted(ports: tuple[str, ...]) -> tuple[tuple[str, object], ...]:
            requests.append(ports)
            return read(ports)

        control.read = counted  # type: ignore[method-assign]
        y, x, again = applier.reads("a", ["gain.y", "gain.x", "gain.y"])
    assert requests == [("gain.y", "gain.x", "gain.y")]
    assert y == again and y % 6 == 0 and 0 < y <= 2 * x  # read at one moment: see above


def test_a_node_that_cannot_be_reached_fails_before_any_step(node_a):
    url = f"socket://127.0.0.1:{free_port()}"
    unreachable = f"robot 'b': cannot open the link to its node at {url}: "
    with pytest.raises(NodeLinkError, match=unreachable):
        LinkApplier.open({"a": node_a.url, "b": url}, **QUICK)
    # Nothing half-done: the link to a was closed, so its node (one host at a time) serves the
    # next manager.
    with LinkApplier.open({"a": node_a.url}, **QUICK) as applier:
        assert applier.node("a").description.startswith("a: ")


def test_a_node_that_stops_answering_fails_the_request_after_the_tries(loaded, node_a):
    url = node_a.url
    with LinkApplier.open({"a": url}, **QUICK) as applier:
        node_a.child.process.send_signal(signal.SIGSTOP)  # the link stays up, nobody answers
        try:
            with pytest.raises(NodeLinkError) as silent:
                applier.migrate("a", loaded.database.module("gain"))
        finally:
            node_a.child.process.send_signal(signal.SIGCONT)
    said = str(silent.value)
    assert said.startswith(f"robot 'a', node at {url}: LS: no answer to ListModules after 3 tries")
    # It waited out every try: at least 0.9 s, more on a busy machine (the figure is the wall
    # clock's). A report pushed just before the node stopped may have been heard: no answer.
    waited = re.search(r"waiting 0\.3 s after each \((\d+\.\d) s in all\): ", said)
    assert waited is not None and float(waited[1]) >= 0.9, said


def test_refusals_name_the_robot_the_url_and_what_the_node_said(loaded, node_a):
    url = node_a.url
    gain = loaded.database.module("gain")
    with LinkApplier.open({"a": url}) as applier:
        with pytest.raises(NodeLinkError, match=r"expected its image installed \(a migrate step"):
            applier.start("a", "gain", gain)
        applier.migrate("a", gain)
        unknown = dataclasses.replace(gain, constants={"q": 1})
        with pytest.raises(NodeLinkError) as refused:
            applier.start("a", "gain", unknown)
        said = str(refused.value)
        assert said.startswith(f"robot 'a', node at {url}: SET gain.q=1: ")
        assert "unknown port 'gain.q'" in said
        assert listed(applier.node("a").control)["gain"][0] == "OFF"  # the node went on

    with (
        NodeProcess(
            "tcp-listen://127.0.0.1:0", "--native", "signal", "--set", "signal.shape=7"
        ) as eager,
        LinkApplier.open({"a": eager.url}) as applier,
    ):
        applier.migrate("a", gain)  # the node starts gain without its k: it is left OFF
        assert listed(applier.node("a").control)["gain"][0] == "OFF"
        applier.start("a", "gain", gain)
        assert listed(applier.node("a").control)["gain"] == ("ON", 50.0)
        assert listed(applier.node("a").control)["signal"][0] == "ERROR"  # refused shape 7
        applier.start("a", "signal", loaded.database.module("signal"))  # cleared, set, started
        assert listed(applier.node("a").control)["signal"][0] == "ON"

    native = loaded.database.module("signal")
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", "--no-start") as bare,
        LinkApplier.open({"a": bare.url}) as applier,
        pytest.raises(NodeLinkError, match="start the node with --native signal"),
    ):
        applier.start("a", "signal", native)


def test_a_node_killed_mid_way_fails_the_next_request_clearly(loaded, node_a):
    url = node_a.url
    current = initial_configuration(loaded.task, loaded.database)
    with LinkApplier.open({"a": url}, **QUICK) as applier:
        maintainer = Maintainer(loaded.database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, current))
        node_a.child.process.kill()
        node_a.child.process.wait(timeout=5)
        with pytest.raises(NodeLinkError, match=f"robot 'a', node at {url}: READ gain.y: "):
            applier.read("a", "gain.y")
        # Stopping gain first undoes the wire into it: the request that meets the dead node.
        unwire = f"robot 'a', node at {url}: DISCONNECT signal.y=gain.x: "
        with pytest.raises(NodeLinkError, match=unwire):
            applier.stop("a", "gain")
        with pytest.raises(NodeLinkError, match="reading its reports"):
            applier.sources()["a"].performance("gain")


def test_a_coalition_bridges_the_port_from_one_node_to_the_other(loaded):
    database = loaded.database
    coalition = Configuration(
        loaded.task.schemas,
        (
            (parse_placement("signal", "a", database),),
            (parse_placement("gain@b", "a", database),),
        ),
    )
    back = configuration(loaded, "signal", "gain")
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--name", "a") as node_a,
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--name", "b") as node_b,
    ):
        urls = {"a": node_a.url, "b": node_b.url}
        with LinkApplier.open(urls) as applier:
            assert applier.host("b") == "127.0.0.1"  # where b's importer listens: its URL's host
            maintainer = Maintainer(database, applier, EventLog())
            maintainer.apply(maintainer.plan(None, coalition))
            assert [(b.number, b.source_robot, b.source) for b in applier.bridges.values()] == [
                (0, "a", "signal.y")
            ]
            a, b = applier.node("a").control, applier.node("b").control
            assert listed(a)["bridge0_tx"][0] == "ON" and listed(b)["bridge0_rx"][0] == "ON"
            wait_until(lambda: applier.read("b", "gain.y") > 0, "gain output across the bridge")
            assert applier.read("b", "gain.y") % 6 == 0  # twice a value of the ramp on a

            maintainer.apply(maintainer.plan(coalition, back))
            assert applier.bridges == {}
            assert "bridge0_tx" not in listed(a) and "bridge0_rx" not in listed(b)
            assert listed(b)["gain"][0] == "OFF" and listed(a)["gain"][0] == "ON"
            wait_until(lambda: applier.read("a", "gain.y") > 0, "gain output on a")


def test_a_plan_deploys_over_a_noisy_pty(loaded):
    current = initial_configuration(loaded.task, loaded.database)
    with NodeProcess("pty", *NODE, "--name", "a") as node:
        path = node.wait_for(r"^listening on (/dev/\S+) ")[1]
        url = f"faulty+{path}#corrupt=0.05&drop=0.05&seed=5"
        with LinkApplier.open({"a": url}, timeout=0.3) as applier:
            maintainer = Maintainer(loaded.database, applier, EventLog())
            maintainer.apply(maintainer.plan(None, current))
            assert listed(applier.node("a").control) == {
                "signal": ("ON", 100.0),
                "gain": ("ON", 50.0),
            }
            source = applier.sources()["a"]
            wait_until(
                lambda: source.performance("gain").latest(PerformanceKind.FUNCTIONAL), "report"
            )
            assert applier.host("a") == "127.0.0.1"  # a pty names no host: the manager's
            counts = applier.node("a").link.counts  # type: ignore[attr-defined]
            assert counts.dropped + counts.corrupted > 0  # the requests were tried again


def test_in_lock_step_the_time_master_learns_each_bridge_and_runs_the_coalition(loaded):
    database = loaded.database
    coalition = Configuration(
        loaded.task.schemas,
        (
            (parse_placement("signal", "a", database),),
            (parse_placement("gain@b", "a", database),),
        ),
    )
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--lock-step", "--name", "a") as node_a,
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--lock-step", "--name", "b") as node_b,
        LinkApplier.open({"a": node_a.url, "b": node_b.url}) as applier,
    ):
        master = TimeMaster(applier.controls(), 0.01)
        applier.router = master
        maintainer = Maintainer(database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, coalition))
        assert master.routes == {0: ("a", "b")}
        assert applier.read("b", "gain.y") == 0  # no time has passed on the nodes
        master.run_until(0.5)
        assert master.counts[0] > 0  # values went over the bridge
        doubled = applier.read("b", "gain.y")
        assert doubled > 0 and doubled % 6 == 0
        source = applier.sources()["b"]
        wait_until(lambda: source.performance("gain").latest(PerformanceKind.FUNCTIONAL), "report")
        assert source.clock is not None and source.clock <= 0.5  # the node's virtual clock

        maintainer.apply(maintainer.plan(coalition, configuration(loaded, "signal", "gain")))
        assert master.routes == {} and applier.bridges == {}
        master.run_until(0.6)  # time goes on without the bridge
        assert applier.read("a", "gain.y") > 0


def test_a_node_that_trusts_keys_takes_the_plan_only_from_a_manager_with_the_key(
    example_builds, tmp_path_factory: pytest.TempPathFactory
):
    """The images signed by the key the node trusts; a manager without the key is refused at
    its first change, named with the robot; with the key the plan deploys and runs."""
    directory = tmp_path_factory.mktemp("trusted")
    key = keys.generate("ed25519")
    (directory / "trusted.pub.pem").write_bytes(keys.public_pem(key.public_key()))
    for name in ("gain", "moving_average"):
        image = sign_image(image_from_elf(example_builds[name].elf), key, Version(1, 0, 0))
        image.write(directory / f"{name}.hex")
    loaded = loads(DATABASE, "filtering.toml", directory)
    current = initial_configuration(loaded.task, loaded.database)
    trust = ("--trust", str(directory / "trusted.pub.pem"))
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE, *trust, "--name", "a") as node:
        url = node.url
        with LinkApplier.open({"a": url}) as stranger:
            maintainer = Maintainer(loaded.database, stranger, EventLog())
            with pytest.raises(NodeLinkError, match=r"robot 'a'.*authentication required"):
                maintainer.apply(maintainer.plan(None, current))
        with LinkApplier.open({"a": url}, key=key) as applier:
            maintainer = Maintainer(loaded.database, applier, EventLog())
            maintainer.apply(maintainer.plan(None, current))
            assert listed(applier.node("a").control) == {
                "signal": ("ON", 100.0),
                "gain": ("ON", 50.0),
            }
            wait_until(lambda: applier.read("a", "gain.y") > 0, "gain output")


HARDWARE = """
[robots.a]
resources.power = { capacity = 100, reserve = 20, report = 0 }
fabric = { slots = ["gain:48:1", "pass"] }

[schemas.source]
kind = "sensor"
[schemas.source.modules.signal]
robots = ["a"]
outputs = { y = "q16" }
needs = { power = 1 }
source = "native"
frequency = 100
constants = { shape = 0, amplitude = 3 }

[schemas.filter]
kind = "computation"
[schemas.filter.modules.fabric]
robots = ["a"]
inputs = { x = "q16" }
outputs = { y = "q16" }
needs = { power = 1 }
source = { bitstreams = ["fabric.slot0.hex"] }
hardware = { functionalities = ["gain"], slots = [0] }
frequency = 100

[task]
name = "tripling"
robot = "a"
states = ["run"]
schemas = ["source", "filter"]
initial = ["signal", "fabric"]
"""
"""A hardware module on the node's fabric: the ``fabric`` native of ``firmware-sim listen`` is
its E-PBO, and slot 0's gain (x * 48 / 16 + 1) computes it once its bitstream routes input 0
through it to output 0."""


def test_a_trusting_node_takes_a_hardware_module_s_signed_bitstream_only_from_its_key(
    tmp_path_factory: pytest.TempPathFactory,
):
    directory = tmp_path_factory.mktemp("hardware")
    key = keys.generate("ed25519")
    (directory / "trusted.pub.pem").write_bytes(keys.public_pem(key.public_key()))
    fabric = fabric_of(["gain:48:1", "pass"])
    bitstream = to_image(fabric, pack(fabric, 0, through_route(fabric, 0)))
    sign_image(bitstream, key, Version(1, 0, 0)).write(directory / "fabric.slot0.hex")
    loaded = loads(HARDWARE, "tripling.toml", directory)
    current = initial_configuration(loaded.task, loaded.database)
    trust = ("--trust", str(directory / "trusted.pub.pem"))
    node_options = ("--fpga", "gain:48:1,pass", "--native", "signal", "--native", "fabric")
    with NodeProcess("tcp-listen://127.0.0.1:0", *node_options, "--no-start", *trust) as node:
        url = node.url
        with LinkApplier.open({"a": url}) as stranger:
            with pytest.raises(NodeLinkError, match=r"robot 'a'.*authentication required"):
                stranger.migrate("a", loaded.database.module("fabric"))
            assert stranger.migrations == []
        with LinkApplier.open({"a": url}, key=key) as applier:
            maintainer = Maintainer(loaded.database, applier, EventLog())
            maintainer.apply(maintainer.plan(None, current))
            (migration,) = applier.migrations
            assert (migration.module, migration.hardware, migration.cycles) == ("fabric", True, 25)
            assert listed(applier.node("a").control)["fabric"] == ("ON", 100.0)

            def tripled() -> bool:
                x, y = applier.reads("a", ["signal.y", "fabric.y"])
                return x > 0 and y == ((int(x) & 0xFF) * 3 + 1) & 0xFF

            wait_until(tripled, "signal through slot 0's gain")
            assert "mx_slot0" in applier.node("a").modules()
            applier.stop("a", "fabric")  # a hardware module that stops lets its slots go
            assert "mx_slot0" not in applier.node("a").modules()
            assert applier.configured == {"a": {}}


def test_a_plan_switches_away_from_a_pbo_that_faulted_into_error(example_builds, tmp_path):
    """The usual repair: the module that failed is in ERROR (its cycle raised, or here its on()
    refused), and a node takes
    STOP only from ON. The stop step takes it out with CLEAR instead (it is OFF after, as a
    stopped PBO), says so on its line, and the plan goes on to the replacement on robot b."""
    image_from_elf(example_builds["gain"].elf).write(tmp_path / "gain.hex")
    image_from_elf(example_builds["moving_average"].elf).write(tmp_path / "moving_average.hex")
    both = DATABASE.replace('robots = ["a"]\noutputs = { y = "q16" }', 'robots = ["a", "b"]\n'
                            'outputs = { y = "q16" }', 1)  # fmt: skip
    loaded = loads(both, "filtering.toml", tmp_path)
    database = loaded.database
    current = initial_configuration(loaded.task, database)
    moved = Configuration(
        loaded.task.schemas,
        (
            (parse_placement("signal@b", "a", database),),
            (parse_placement("gain", "a", database),),
        ),
    )
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--name", "a") as node_a,
        NodeProcess("tcp-listen://127.0.0.1:0", *NODE, "--name", "b") as node_b,
        LinkApplier.open({"a": node_a.url, "b": node_b.url}) as applier,
    ):
        log = EventLog()
        maintainer = Maintainer(database, applier, log)
        maintainer.apply(maintainer.plan(None, current))
        a = applier.node("a").control
        # Signal fails: started again as a square wave of period 0 ms, which its on() refuses.
        a.stop("signal")
        a.set("signal.shape=2")
        a.set("signal.period_ms=0")
        with pytest.raises(TransferError, match="START refused"):
            a.start("signal")
        assert listed(a)["signal"][0] == "ERROR"

        timings = maintainer.apply(maintainer.plan(current, moved))
        assert [str(t.step) for t in timings] == [
            "stop signal on a",
            "start signal on b",
            "connect signal.y@b -> gain.x@a",
        ]
        assert listed(a)["signal"][0] == "OFF"  # cleared, as a stop leaves it
        assert listed(applier.node("b").control)["signal"] == ("ON", 100.0)
        stop = next(e for e in log.of_kind("step") if e.data["action"] == "stop")
        assert stop.message.startswith("stop signal on a: it was in ERROR: cleared to OFF (")
        assert stop.data["note"] == "it was in ERROR: cleared to OFF"
        wait_until(lambda: applier.read("a", "gain.y") > 0, "gain fed across the bridge")
        # Back again: signal on a starts from OFF (the database's ramp), b's is stopped as usual.
        maintainer.apply(maintainer.plan(moved, current))
        assert listed(a)["signal"] == ("ON", 100.0)
        assert "note" not in log.of_kind("step")[-3].data


def test_a_module_the_node_lists_otherwise_is_sent_again_and_a_skip_says_so(loaded, node_a):
    """Nodes outlive managers: a module edited and rebuilt since a node got it is sent again in
    place of the old one when its size or its CRC-32 in flash differs from what the node lists
    (LS: name, address, size, CRC-32 of the bytes relocated there), a rebuild of the same size
    too; the same image is not sent, and the step's line says so instead of claiming a
    migration."""
    database = loaded.database
    gain = database.module("gain")
    rebuilt = migration_image(gain, {})  # the database's file, as a manager sends it
    older = dataclasses.replace(rebuilt, data=rebuilt.data + bytes(64))  # an older build
    same_size = dataclasses.replace(rebuilt, data=rebuilt.data + b"\x01" * 64)  # and another
    size, padded = rebuilt.size, older.size
    with LinkApplier.open({"a": node_a.url}, images={"gain": older}) as first:
        assert first.migrate("a", gain) is None  # the node had none: sent, nothing to note

    def migrated(images: dict[str, ModuleImage]) -> tuple[str, list[Migration]]:
        """What a manager's first deployment said of gain's migration, and what it sent."""
        with LinkApplier.open({"a": node_a.url}, images=images) as applier:
            applier.node("a").control.reset()  # as a manager does before it deploys
            log = EventLog()
            maintainer = Maintainer(database, applier, log)
            maintainer.apply(maintainer.plan(None, initial_configuration(loaded.task, database)))
            assert listed(applier.node("a").control)["gain"] == ("ON", 50.0)
            (step,) = [e for e in log.of_kind("step") if e.data["action"] == "migrate"]
            return step.message, applier.migrations

    def where() -> int:
        """Where the node lists gain."""
        with LinkApplier.open({"a": node_a.url}) as applier:
            return next(m.address for m in applier.node("a").sender.modules() if m.name == "gain")

    def crc(image: ModuleImage, address: int) -> str:
        return f"0x{zlib.crc32(image.relocate(address)):08X}"

    address = where()
    message, sent = migrated({"gain": same_size})
    replaced = (
        f"in place of the gain on a ({padded} bytes as the image, but CRC-32 "
        f"{crc(older, address)} in its flash at 0x{address:08X}, where the image would have "
        f"{crc(same_size, address)})"
    )
    assert message.startswith(f"migrate gain to a: {replaced} (")
    assert [m.module for m in sent] == ["gain"]

    message, sent = migrated({})
    replaced = f"in place of the gain on a ({padded} bytes on the node, {size} in the image)"
    assert message.startswith(f"migrate gain to a: {replaced} (")
    assert [m.module for m in sent] == ["gain"]

    address = where()
    message, sent = migrated({})
    kept = (
        f"already on a ({size} bytes and CRC-32 {crc(rebuilt, address)} at 0x{address:08X}, "
        "as the image)"
    )
    assert message.startswith(f"migrate gain to a: {kept}, not sent (")
    assert sent == []
    registered = [line for line in node_a.lines() if line.startswith("registered gain")]
    assert len(registered) == 3  # the older build, the other one, the rebuild; not a fourth time
