"""Hardware modules in ReFrESH: declared against a robot's fabric, checked by ``refresh check``,
proposed and judged by the Generator (a fabric's slots bound what fits), planned and migrated as
partial bitstreams, and run by an E-PBO whose data flows through the fabric."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.core.node import Node
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import INPUT_SEL, NONE_SEL, Source, SourceKind
from morphing_crossbar.fabric_spec import fabric_of
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.reconfiguration_port import CrossbarReconfigurationPort
from morphing_crossbar.routing import SlotRoute, through_route
from pbort import NativeModule, NativePBO, PerformanceKind, PortIO, PortSpec
from pbort.clock import VirtualClock
from refresh.appliers.in_memory import MemoryApplier
from refresh.appliers.in_process import NodeApplier
from refresh.cli import main as refresh_main
from refresh.configuration import initial_configuration
from refresh.database import Placement
from refresh.errors import ApplyError, DatabaseError, DatabaseImageError
from refresh.events import EventLog
from refresh.hardware import check_hardware, host_codes, node_codes, route
from refresh.load import Loaded, load
from refresh.maintainer import Maintainer, plan
from refresh.performance import assess, usage

SLOTS = ["gain:32:5", "fir:4929:3", "pass", "gain:16:1"]
"""A fabric whose slot 0 doubles and adds 5, slot 3 adds 1 (gain's p0 has four fraction bits)."""
FABRIC = fabric_of(SLOTS, 16)


def bitstream(directory: Path, name: str, slot: int, route: SlotRoute) -> str:
    """A partial bitstream for `slot` of FABRIC written to `directory`; its file name."""
    to_image(FABRIC, pack(FABRIC, slot, route)).write(directory / name)
    return name


def database_text(directory: Path, extra: str = "", slot1: SlotRoute | None = None) -> str:
    """A task whose filter slot runs Soft (native) or Doubler in hardware on slots 0 and 3."""
    head = bitstream(directory, "head.hex", 0, SlotRoute(INPUT_SEL, NONE_SEL))
    # slot 3 reads slot 0's functionality over the local crossbar (the ring would give slot 2's)
    local = FABRIC.selector(3, Source(SourceKind.FUNCTION, 0))
    tail = bitstream(directory, "tail.hex", 3, slot1 or SlotRoute(local, FABRIC.self_selector(3)))
    slots = ", ".join(f'"{s}"' for s in SLOTS)
    return f"""
[robots.r]
resources.power = {{ capacity = 100, reserve = 20, report = 0 }}
fabric = {{ slots = [{slots}], width = 16 }}

[robots.plain]
resources.power = {{ capacity = 100, reserve = 20 }}

[schemas.sensor]
kind = "sensor"
[schemas.sensor.modules.Source]
robots = ["r"]
outputs = {{ y = "level" }}
source = "native"

[schemas.filter]
kind = "computation"
[schemas.filter.modules.Soft]
robots = ["r"]
inputs = {{ x = "level" }}
outputs = {{ y = "filtered" }}
needs = {{ power = 50 }}
source = "native"
[schemas.filter.modules.Doubler]
robots = ["r"]
inputs = {{ x = "level" }}
outputs = {{ y = "filtered" }}
needs = {{ power = 5 }}
source = {{ bitstreams = ["{head}", "{tail}"] }}
hardware = {{ functionalities = ["gain", "gain"], slots = [0, 3] }}
{extra}
[task]
name = "t"
robot = "r"
states = ["run"]
schemas = ["sensor", "filter"]
initial = ["Source", "Soft"]
"""


def one_slot_module(name: str, bitstream: str) -> str:
    """The TOML of hardware module `name` on r's slot 0 (its gain), routed by `bitstream`."""
    return f"""
[schemas.filter.modules.{name}]
robots = ["r"]
inputs = {{ x = "level" }}
outputs = {{ y = "filtered" }}
source = {{ bitstreams = ["{bitstream}"] }}
hardware = {{ functionalities = ["gain"], slots = [0] }}
"""


def loaded(tmp_path: Path, extra: str = "", slot1: SlotRoute | None = None) -> Loaded:
    file = tmp_path / "db.toml"
    file.write_text(database_text(tmp_path, extra, slot1))
    return load(file)


def test_a_hardware_module_routes_its_stream_through_the_functionalities_it_declares(tmp_path):
    database = loaded(tmp_path).database
    module = database.module("Doubler")
    assert str(module.hardware) == "gain@slot0 -> gain@slot3"
    found = route(module, database.robots["r"])
    assert (found.input, found.functions, found.output) == (0, (0, 3), 3)
    check_hardware(database, "db.toml")


def test_refresh_check_shows_the_fabric_and_the_hardware(tmp_path, capsys):
    loaded(tmp_path)
    assert refresh_main(["check", str(tmp_path / "db.toml")]) == 0
    out = capsys.readouterr().out
    assert "  fabric gain:32:5,fir:4929:3,pass,gain:16:1 (16-bit samples)" in out
    assert "    in hardware: gain@slot0 -> gain@slot3" in out


def test_bitstreams_that_route_elsewhere_fail_refresh_check(tmp_path, capsys):
    loaded(tmp_path, slot1=through_route(FABRIC, 3))  # slot 3 reads its own input, not the ring
    assert refresh_main(["check", str(tmp_path / "db.toml")]) == 1
    err = capsys.readouterr().err
    assert "expected bitstreams routing gain@slot0 -> gain@slot3 on robot 'r'" in err
    assert "expected its bitstreams to route one input through slots 0, 3" in err


def test_a_missing_bitstream_fails_refresh_check_by_name(tmp_path):
    database = loaded(tmp_path).database
    (tmp_path / "tail.hex").unlink()
    with pytest.raises(DatabaseImageError, match=r"tail\.hex"):
        check_hardware(database, "db.toml")


@pytest.mark.parametrize("named", ["/dev/zero", "/tmp", "/nonexistent.hex"])
def test_a_bitstream_that_is_no_file_is_refused_without_reading_it(tmp_path, named):
    text = database_text(tmp_path).replace('"tail.hex"]', f'"{named}"]')
    (tmp_path / "db.toml").write_text(text)
    database = load(tmp_path / "db.toml").database
    with pytest.raises(DatabaseImageError, match=r"Doubler\.source\.bitstreams: expected"):
        check_hardware(database, "db.toml")


@pytest.mark.parametrize(
    ("change", "where", "expected"),
    [
        (
            ("slots = [0, 3]", "slots = [0, 2]"),
            "schemas.filter.modules.Doubler.hardware",
            "expected gain in slot 2 of robot 'r''s fabric, got pass",
        ),
        (
            ("slots = [0, 3]", "slots = [0]"),
            "schemas.filter.modules.Doubler.hardware.slots",
            "expected a slot per functionality (2)",
        ),
        (
            (
                'robots = ["r"]\ninputs = { x = "level" }\noutputs = { y = "filtered" }\n'
                "needs = { power = 5 }",
                'robots = ["plain"]\ninputs = { x = "level" }\n'
                'outputs = { y = "filtered" }\nneeds = {}',
            ),
            "schemas.filter.modules.Doubler.robots",
            "robots with an FPGA fabric ('plain' has none)",
        ),
        (
            ('"gain:32:5", "fir', '"gain:32:5:7", "fir'),
            "robots.r.fabric",
            "expected a fabric the Morphing Crossbar can build",
        ),
        (("hardware = {", "unused = {"), "schemas.filter.modules.Doubler", "unknown key"),
    ],
)
def test_a_database_that_declares_hardware_its_robots_lack_is_refused_where(
    tmp_path, change, where, expected
):
    text = database_text(tmp_path)
    assert change[0] in text
    (tmp_path / "db.toml").write_text(text.replace(*change, 1))
    with pytest.raises(DatabaseError) as raised:
        load(tmp_path / "db.toml")
    assert where in str(raised.value)
    assert expected in str(raised.value)


def test_a_bitstream_source_without_its_hardware_table_is_refused(tmp_path):
    text = database_text(tmp_path).replace(
        'hardware = { functionalities = ["gain", "gain"], slots = [0, 3] }\n', ""
    )
    (tmp_path / "db.toml").write_text(text)
    with pytest.raises(DatabaseError, match=r"Doubler\.hardware: expected the fabric"):
        load(tmp_path / "db.toml")


def test_a_fabric_s_slots_claimed_twice_fail_equation_one_and_count_nothing_in_util(tmp_path):
    result = loaded(tmp_path)
    database, task = result.database, result.task
    current = initial_configuration(task, database)
    used = usage(current.replace(1, (Placement("Doubler", "r"),)), database)
    assert used[("r", "fabric.slot0")] == 1.0
    judged = assess(used, {}, task, database, ["r"])
    assert judged.nonfunctional[("r", "fabric")] == 1
    assert judged.util_nf == {"power": 5.0}  # the slots are no resource Util sums
    twice = {**used, ("r", "fabric.slot3"): 2.0}
    assert assess(twice, {}, task, database, ["r"]).nonfunctional[("r", "fabric")] == 0


def test_the_plan_says_the_module_runs_in_hardware(tmp_path):
    result = loaded(tmp_path)
    database, task = result.database, result.task
    current = initial_configuration(task, database)
    target = current.replace(1, (Placement("Doubler", "r"),))
    steps = [str(step) for step in plan(current, target, database).steps]
    assert "migrate Doubler to r (partial bitstreams to its fabric)" in steps
    assert "start Doubler (in hardware) on r" in steps
    back = [str(step) for step in plan(target, current, database).steps]
    assert "stop Doubler (in hardware) on r" in back


def test_an_applier_sends_a_hardware_module_once_and_again_after_its_node_rejoins(tmp_path):
    database = loaded(tmp_path).database
    applier = MemoryApplier(database.robots)
    module = database.module("Doubler")
    applier.migrate("r", module)
    applier.migrate("r", module)
    assert [(m.module, m.hardware) for m in applier.migrations] == [("Doubler", True)]
    assert applier.configured == {"r": {0: "Doubler", 3: "Doubler"}}
    assert applier.rejoin("r") is not None
    applier.migrate("r", module)
    assert [m.module for m in applier.migrations] == ["Doubler", "Doubler"]


def test_a_hardware_module_whose_slot_another_took_meanwhile_is_sent_again(tmp_path):
    other = bitstream(tmp_path, "other.hex", 0, through_route(FABRIC, 0))
    extra = one_slot_module("Other", other)
    database = loaded(tmp_path, extra).database
    applier = MemoryApplier(database.robots)
    for name in ("Doubler", "Other", "Other", "Doubler"):
        applier.migrate("r", database.module(name))
    assert [m.module for m in applier.migrations] == ["Doubler", "Other", "Doubler"]
    assert applier.configured == {"r": {0: "Doubler", 3: "Doubler"}}


class Ramp(NativePBO):
    name = "Source"
    ports = (PortSpec.output("y", dtype="<i2"),)

    def init(self, io: PortIO) -> None:
        self.value = -3

    def cycle(self, io: PortIO) -> None:
        self.value += 1
        io["y"] = self.value


PORTS = {"Doubler": (PortSpec.input("x", dtype="<i2"), PortSpec.output("y", dtype="<i2"))}
"""The E-PBO's ports: int16, as wide as the fabric's samples, so they cross as two's complement."""


def test_in_process_the_bitstreams_reach_the_node_s_fabric_and_the_data_flows_through(tmp_path):
    database = loaded(tmp_path).database
    port = CrossbarReconfigurationPort(CrossbarModel(FABRIC))
    with Node("r", clock=VirtualClock(), fpga=port) as node:
        natives = {"Source": NativeModule(Ramp)} | node_codes(database, "r", port, PORTS)
        applier = NodeApplier({"r": node}, natives)
        module = database.module("Doubler")
        applier.migrate("r", module)
        assert "in0 -> fn0 -> fn3 -> out3" in port.model.configuration.describe().splitlines()
        applier.start("r", "Source", database.module("Source"))
        applier.start("r", "Doubler", module)
        applier.connect("r", "Source.y", "Doubler.x", "r")
        seen: list[int] = []
        node.kernel.observe(
            lambda pbo, _t: (
                seen.append(int(node.kernel.value("Doubler.y"))) if pbo == "Doubler" else None
            )
        )
        node.run(until=1.0)  # the database's 10 Hz
    # x = -2, -1, 0, 1 ...: (2x + 5) then (x + 1), in 16-bit two's complement, signed again.
    expected = [2 * x + 5 + 1 for x in range(-2, 3)]
    assert seen[1 : len(expected) + 1] == expected or seen[: len(expected)] == expected


def test_the_estimator_streams_through_a_model_of_the_fabric_with_the_module_s_bitstreams(
    tmp_path,
):
    database = loaded(tmp_path).database
    code = host_codes(database, PORTS)["Doubler@r"]
    with (
        Node("host", clock=VirtualClock()) as host,
        host.kernel.shadow([("Doubler", code)], (), {"Doubler.x": 7}) as run,
    ):
        estimates = run.run(1)
    assert estimates["Doubler"].failure is None
    assert estimates["Doubler"].outputs["y"] == 2 * 7 + 5 + 1
    assert estimates["Doubler"].latest(PerformanceKind.NON_FUNCTIONAL, 0) == 5.0  # its power


def test_a_hardware_module_whose_ports_the_application_does_not_give_is_refused(tmp_path):
    database = loaded(tmp_path).database
    with pytest.raises(ApplyError, match="expected the ports of its E-PBO from the application"):
        host_codes(database, {})


@pytest.mark.parametrize(
    ("ports", "got"),
    [
        ((PortSpec.input("u"), PortSpec.output("y")), "got an E-PBO from u to y"),
        ((PortSpec.input("x"), PortSpec.output("out")), "got an E-PBO from x to out"),
    ],
)
def test_a_hardware_module_whose_e_pbo_s_ports_are_not_the_database_s_is_refused_before_it_runs(
    tmp_path, ports, got
):
    database = loaded(tmp_path).database
    expected = "hardware module Doubler: expected the E-PBO's ports to be the database's, x to y"
    for make in (
        lambda: host_codes(database, {"Doubler": ports}),
        lambda: node_codes(
            database, "r", CrossbarReconfigurationPort(CrossbarModel(FABRIC)), {"Doubler": ports}
        ),
    ):
        with pytest.raises(ApplyError, match=f"{expected}.*{got}"):
            make()


def test_a_migration_that_fails_midway_leaves_no_slot_counted_as_configured(tmp_path):
    other = bitstream(tmp_path, "other.hex", 0, through_route(FABRIC, 0))
    extra = one_slot_module("Other", other)
    database = loaded(tmp_path, extra).database

    class Refusing(MemoryApplier):
        """Refuses Doubler's second bitstream: its first (slot 0) was applied."""

        def _send(self, robot, module, image):
            self.sent = getattr(self, "sent", 0) + 1
            if module.name == "Doubler" and self.sent == 3:
                raise ApplyError("refused")
            return super()._send(robot, module, image)

    applier = Refusing(database.robots)
    applier.migrate("r", database.module("Other"))
    with pytest.raises(ApplyError, match="refused"):
        applier.migrate("r", database.module("Doubler"))
    applier.migrate("r", database.module("Other"))  # slot 0 is Doubler's head now: again
    assert [m.module for m in applier.migrations] == ["Other", "Other"]


def test_bitstreams_a_fresh_node_s_fabric_would_refuse_fail_refresh_check(tmp_path):
    # Slot 0 reads input 1 over the local crossbar: a route on an empty fabric, but after reset
    # slot 1 reads input 1 itself, and a stream has one consumer (the node refuses the commit).
    selector = FABRIC.selector(0, Source(SourceKind.INPUT, 1))
    name = bitstream(tmp_path, "x.hex", 0, SlotRoute(selector, FABRIC.self_selector(0)))
    extra = one_slot_module("X", name)
    database = loaded(tmp_path, extra).database
    with pytest.raises(DatabaseImageError) as raised:
        check_hardware(database, "db.toml")
    message = str(raised.value)
    assert "X.source.bitstreams: expected bitstreams routing gain@slot0 on robot 'r'" in message
    assert "expected its bitstreams, sent in order, to apply to its fabric after reset" in message
    assert "expected one consumer of in1" in message


@pytest.mark.parametrize("slot", ["gain: 32\\r:5", "gain:32:5\\u001b[2J", "gain:32 :5"])
def test_a_fabric_slot_with_spaces_or_control_characters_is_refused_where(tmp_path, slot):
    # The crossbar's parser skips them, but refresh check would print them to a terminal.
    text = database_text(tmp_path).replace('"gain:32:5"', f'"{slot}"')
    (tmp_path / "db.toml").write_text(text)
    with pytest.raises(DatabaseError, match=r"robots\.r\.fabric\.slots\[0\]: expected a name"):
        load(tmp_path / "db.toml")


def test_a_hardware_module_replaces_another_on_shared_slots_once_it_let_them_go(tmp_path):
    other = bitstream(tmp_path, "other.hex", 0, through_route(FABRIC, 0))
    extra = one_slot_module("Other", other)
    result = loaded(tmp_path, extra)
    database, task = result.database, result.task
    ports = {**PORTS, "Other": PORTS["Doubler"]}
    port = CrossbarReconfigurationPort(CrossbarModel(FABRIC))
    doubling = initial_configuration(task, database).replace(1, (Placement("Doubler", "r"),))
    other = doubling.replace(1, (Placement("Other", "r"),))
    steps = [str(step) for step in plan(doubling, other, database).steps]
    # Other's bitstream for slot 0 waits for Doubler's stop, which empties slots 0 and 3.
    assert steps.index("stop Doubler (in hardware) on r") < steps.index(
        "migrate Other to r (partial bitstreams to its fabric)"
    )
    with Node("r", clock=VirtualClock(), fpga=port) as node:
        natives = {"Source": NativeModule(Ramp)} | node_codes(database, "r", port, ports)
        maintainer = Maintainer(database, NodeApplier({"r": node}, natives), EventLog())
        maintainer.apply(maintainer.plan(None, doubling))
        node.run(until=0.5)
        maintainer.apply(maintainer.plan(doubling, other))
        node.run(until=1.0)
        routes = port.model.configuration.describe().splitlines()
        assert "in0 -> fn0 -> out0" in routes  # Other's; slot 3 emptied when Doubler stopped
        assert not any("fn3" in route for route in routes)
        assert node.kernel.value("Other.y") == 2 * int(node.kernel.value("Source.y")) + 5
