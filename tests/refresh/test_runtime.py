"""The runtime on a task of one's own (tests/refresh/line_follower.py): deployment, detection,
repair, recovery, settling, safe stop, and the traps a new user hit before it existed: the first
deployment needed `plan(None, ...)`, estimators judged the time before the fault, the event log
printed wall-clock times in a virtual-time run, and a metric module's default 10 Hz starved a
faster Decider."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import pytest

from firmware_sim.core.node import Node
from pbort import Kernel
from pbort.performance_buffer import PerformanceBuffer
from refresh.appliers.in_process import NodeApplier
from refresh.configuration import initial_configuration
from refresh.decider import Decider
from refresh.errors import ApplyError, ConfigurationError, RateError, UnreportedMetric
from refresh.estimators.host import HostEstimators
from refresh.events import Event, EventLog
from refresh.location import STRATEGIES
from refresh.manager.event_stream import MAX_EVENT, line
from refresh.runtime import Runtime, RuntimeSettings
from tests.refresh.line_follower import (
    ROBOT,
    SETTINGS,
    advance,
    database,
    load,
    natives,
    rover,
)

FAULT_AT = 1.0
REPAIRED = "{Sensor_alt, Steer}"


def test_deploy_starts_the_initial_configuration_with_its_constants():
    with rover(FAULT_AT) as (runtime, node):
        deployed = runtime.deploy()
        assert deployed.label() == "{Sensor, Steer}"
        assert runtime.current == deployed
        assert set(node.kernel.names) == {"Sensor", "Steer"}
        assert node.kernel.value("Sensor.bias") == 2.0  # the database's constant
        assert ("Sensor.line", "Steer.line") in node.kernel.connections()
        node.run(until=0.5)
        assert runtime.value("steering", "angle") == pytest.approx(1.2)
        assert runtime.history.configurations == [(0.0, "{Sensor, Steer}")]


def test_a_runtime_deploys_once():
    with rover(FAULT_AT) as (runtime, _node):
        runtime.deploy()
        with pytest.raises(ConfigurationError, match="expected a runtime that has not deployed"):
            runtime.deploy()


def test_nothing_is_judged_before_the_deployment():
    with rover(FAULT_AT) as (runtime, node):
        node.run(until=2.0)
        assert runtime.step() is None
        assert len(runtime.log) == 0
        with pytest.raises(ConfigurationError, match="expected a running configuration"):
            runtime.value("steering", "angle")


def test_run_refuses_an_advance_that_does_not_move_the_clock():
    with rover(FAULT_AT) as (runtime, node):
        runtime.deploy()
        with pytest.raises(ConfigurationError, match="expected the runtime's clock to move on"):
            runtime.run(1.0, lambda seconds: None)
        runtime.run(0.0, advance(node))  # nothing left to run
        assert node.kernel.now == 0.0


def test_the_fault_is_detected_located_and_repaired_and_the_task_recovers():
    with rover(FAULT_AT) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        (record,) = runtime.history.reconfigurations
        assert record.detected_at == pytest.approx(1.2)  # 2 violating looks after the fault
        assert record.decision.location.module == "Sensor"
        assert record.test_cases == 1 and record.brute_force == 2
        assert record.target is not None and record.target.label() == REPAIRED
        assert record.applied_at == pytest.approx(1.2)
        assert record.recovered_at == pytest.approx(1.3)  # the first look after the switch
        assert set(node.kernel.names) == {"Sensor_alt", "Steer"}
        assert [label for _, label in runtime.history.configurations] == [
            "{Sensor, Steer}",
            REPAIRED,
        ]
        assert runtime.history.stopped_at is None
        (recovered,) = runtime.log.of_kind("recovered")
        assert recovered.time == pytest.approx(1.6)  # held for 0.3 s


def test_compared_strategies_locate_in_shadow_and_the_decision_stays_the_task_s():
    settings = replace(SETTINGS, compare_locations=True)
    with rover(FAULT_AT, settings=settings) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        (record,) = runtime.history.reconfigurations
        assert list(record.comparison) == list(STRATEGIES)
        for name, location in record.comparison.items():
            assert location.strategy == name
            assert location.modules == ("Sensor",)
        assert record.decision.location.strategy == "base-choice"
        assert record.comparison["base-choice"] is record.decision.location  # not estimated twice
        assert record.target is not None and record.target.label() == REPAIRED
        assert [e.kind for e in runtime.log].count("location") == 1  # shadows log elsewhere


def test_estimators_judge_the_time_of_the_decision_not_the_host_s_own():
    """With the host kernel left at 0, Sensor's estimator read the offset from before the fault,
    so {Sensor, Filter, Steer} looked good and cheapest, was chosen, and failed at once."""
    with rover(FAULT_AT) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        (record,) = runtime.history.reconfigurations
        combo = record.decision.choice.candidates[1][1]
        assert combo.values["error"] == pytest.approx((2 + 100) / 2)  # after the fault
        assert combo.p_t == 0
        assert record.target.label() == REPAIRED
        assert runtime.log.of_kind("violation")[-1].time < record.detected_at  # no flip-flop


def test_the_event_log_runs_on_the_runtime_s_virtual_clock():
    with rover(FAULT_AT) as (runtime, node):
        runtime.deploy()
        runtime.run(2.0, advance(node))
        (detection,) = runtime.log.of_kind("detection")
        assert detection.time == runtime.history.reconfigurations[0].detected_at
        assert [e.time for e in runtime.log.of_kind("violation")] == pytest.approx([1.1])
        assert all(e.time == 0.0 for e in runtime.log.of_kind("step")[:3])  # the deployment


def test_a_detection_during_the_settle_time_is_not_acted_on():
    settings = RuntimeSettings(
        decision_period=0.1, debounce=1, settle=0.5, recovery_hold=0.3, estimate_steps=3
    )
    with rover(0.05, settings=settings) as (runtime, node):
        runtime.deploy()
        runtime.run(1.0, advance(node))
        detections = [e.time for e in runtime.log.of_kind("detection")]
        assert detections[:4] == pytest.approx([0.1, 0.2, 0.3, 0.4])  # declared, not acted on
        (record,) = runtime.history.reconfigurations
        assert record.detected_at == pytest.approx(0.5)


def test_violating_looks_while_the_configuration_settles_count_towards_no_detection():
    """A loop still settling after a switch (in real time, further behind after a slow switch)
    violates: those looks are not the new configuration's fault. Counting them, a run beside
    two CPU hogs declared a fault 0.52 s after its repair and repaired again, wrongly."""
    settings = RuntimeSettings(
        decision_period=0.1, debounce=3, settle=0.5, recovery_hold=0.3, estimate_steps=3
    )
    with rover(0.05, settings=settings) as (runtime, node):
        runtime.deploy()
        runtime.run(1.0, advance(node))
        (record,) = runtime.history.reconfigurations
        assert record.detected_at == pytest.approx(0.7)  # looks at 0.5, 0.6 and 0.7


def test_when_nothing_helps_the_task_is_stopped_safely():
    with rover(FAULT_AT, alt_broken=True) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        (record,) = runtime.history.reconfigurations
        assert record.target is None and record.applied_at is None
        assert runtime.history.stopped_at == pytest.approx(1.2)
        assert runtime.current is None
        assert node.kernel.names == ()  # every module stopped and removed
        (stopped,) = runtime.log.of_kind("stopped")
        assert stopped.data["reason"] == "more than one fault suspected"
        assert runtime.step() is None  # nothing runs: nothing to judge


def test_a_metric_no_module_reports_is_a_configuration_error_not_a_double_fault():
    """A metric at an index no module reports (the tutorial's database with ``index = 3``) made
    a violation of every look, then "more than one fault suspected" and a safe stop, as if two
    modules had failed. Its module reports other values all along: the runtime now says the
    metric is unreported and stops with an error, locating nothing."""
    loaded = load(database().replace("index = 0", "index = 3"))
    assert loaded.task is not None
    codes = natives(FAULT_AT)
    with Node(ROBOT) as node, Kernel() as host:
        runtime = Runtime(
            loaded.database,
            loaded.task,
            NodeApplier({ROBOT: node}, natives=codes),
            HostEstimators(host, codes, loaded.database, loaded.task),
            lambda: node.kernel.now,
            SETTINGS,
        )
        runtime.deploy()
        said = (
            r"no module reports error \(functional index 3 of the module filling schema "
            r"steering\): Steer on rover reports functional 0, non-functional 0, but not "
            r"functional 3 in 2 look\(s\): check the database's task.metrics.error"
        )
        with pytest.raises(UnreportedMetric, match=said):
            runtime.run(3.0, advance(node))
    assert node.kernel.now < FAULT_AT  # at the first debounce, long before any fault
    assert not runtime.history.reconfigurations
    kinds = {event.kind for event in runtime.log}
    assert not kinds & {"detection", "location", "stopped"}
    (event,) = runtime.log.of_kind("unreported_metric")
    assert event.data == {
        "metric": "error",
        "schema": "steering",
        "index": 3,
        "instance": "Steer",
        "robot": ROBOT,
        "reported": [["functional", 0], ["non-functional", 0]],
    }


def test_a_metric_module_that_reported_nothing_at_all_may_be_the_fault():
    """Silence from the metric's module (its evaluator dead) is no evidence against the
    database: the Decider declares the fault, for the Locator to judge."""
    loaded = load()
    assert loaded.task is not None
    current = initial_configuration(loaded.task, loaded.database)
    decider = Decider(loaded.task, loaded.database, EventLog(), debounce=2)
    silent = {ROBOT: SimpleNamespace(performance=lambda name: PerformanceBuffer())}
    assert decider.step(current, silent) is None
    detection = decider.step(current, silent)
    assert detection is not None and detection.assessment.values == {"error": None}


def test_repairs_that_keep_failing_stop_the_task_after_the_attempts_allowed():
    """Estimators that see no fault make every repair look good and none works: without a bound
    the runtime switched between the two sensors every settle time until the run ended."""
    settings = replace(SETTINGS, repair_attempts=3)
    with rover(FAULT_AT, alt_broken=True, settings=settings, blind=True) as (runtime, node):
        runtime.deploy()
        runtime.run(6.0, advance(node))
        records = runtime.history.reconfigurations
        assert len(records) == 3
        assert all(r.target is not None and r.recovered_at is None for r in records)
        assert len(runtime.history.configurations) == 1 + 3  # switched three times, then no more
        (stopped,) = runtime.log.of_kind("stopped")
        assert stopped.data["reason"] == "3 repairs in a row did not bring P_T back"
        assert runtime.history.stopped_at is not None and runtime.current is None
        assert node.kernel.names == ()


def test_a_repair_that_held_counts_no_failed_attempt():
    settings = replace(SETTINGS, repair_attempts=1)
    with rover(FAULT_AT, settings=settings) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        assert runtime.history.failed_repairs() == 0
        assert runtime.history.stopped_at is None


class UnreachableSensorApplier(NodeApplier):
    """A node applier whose stop of Sensor fails, as over a link that broke."""

    def stop(self, robot: str, instance: str) -> None:
        if instance == "Sensor":
            raise ApplyError(f"stop {instance} on {robot}: the node does not answer")
        super().stop(robot, instance)


class StoppedBridgeApplier(NodeApplier):
    """A node applier one of whose bridges stopped, as a relay of the manager's does."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.to_say = ["bridge3 from Sensor.line on mars, relayed by the manager, stopped: x"]

    def stopped_bridges(self) -> list[str]:
        said, self.to_say = self.to_say, []
        return said


def test_a_bridge_that_stopped_is_an_event_of_the_run():
    with rover(FAULT_AT, applier_class=StoppedBridgeApplier) as (runtime, node):
        runtime.deploy()
        runtime.run(1.0, advance(node))
    (stopped,) = runtime.log.of_kind("bridge_stopped")
    assert stopped.message.startswith("bridge3 from Sensor.line on mars, relayed by the manager")


def test_a_module_that_cannot_be_stopped_does_not_keep_the_others_running():
    with rover(FAULT_AT, alt_broken=True, applier_class=UnreachableSensorApplier) as (
        runtime,
        node,
    ):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        assert runtime.history.stopped_at is not None
        (failed,) = runtime.log.of_kind("stop_failed")
        assert failed.data["instance"] == "Sensor" and "does not answer" in failed.message
        assert node.kernel.names == ("Sensor",)  # Steer was stopped all the same


def test_a_metric_module_slower_than_the_decider_is_refused_naming_rate_and_period():
    """Steer without a frequency runs at the database's default 10 Hz: a Decider looking every
    0.01 s would count one stale report ten times."""
    loaded = load(database(steer_frequency=""))
    settings = RuntimeSettings(decision_period=0.01)
    with Node(ROBOT) as node, Kernel() as host:
        applier = NodeApplier({ROBOT: node}, natives=natives(FAULT_AT))
        estimators = HostEstimators(host, {}, loaded.database, loaded.task)
        with pytest.raises(RateError) as error:
            Runtime(loaded.database, loaded.task, applier, estimators, lambda: 0.0, settings)
        assert node.kernel.names == ()  # refused before anything was deployed
    message = str(error.value)
    assert "'Steer'" in message and "10 Hz" in message and "0.01 s" in message
    assert "at least 100 Hz" in message
    # At the rate the Decider looks, it is accepted.
    RuntimeRateCheck.accepts(database(steer_frequency=""), RuntimeSettings(decision_period=0.1))


def test_the_rate_rule_covers_the_last_module_of_a_combo_in_a_metric_slot():
    smoother = """
[schemas.filter.modules.Smoother]
robots = ["rover"]
inputs = { raw = "steer_angle" }
outputs = { angle = "steer_angle" }
needs = { power = 1 }
source = "native"
frequency = 5
"""
    with pytest.raises(RateError, match="module 'Smoother' reports metric 'error' at 5 Hz"):
        RuntimeRateCheck.accepts(database(extra=smoother), SETTINGS)


class RuntimeRateCheck:
    """Makes a runtime over a database without running it."""

    @staticmethod
    def accepts(text: str, settings: RuntimeSettings) -> None:
        loaded = load(text)
        with Node(ROBOT) as node, Kernel() as host:
            applier = NodeApplier({ROBOT: node}, natives=natives(FAULT_AT))
            estimators = HostEstimators(host, {}, loaded.database, loaded.task)
            Runtime(loaded.database, loaded.task, applier, estimators, lambda: 0.0, settings)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("decision_period", 0.0),
        ("decision_period", -0.1),
        ("decision_period", math.nan),
        ("decision_period", math.inf),
        ("settle", -1.0),
        ("recovery_hold", math.nan),
        ("debounce", 0),
        ("debounce", 2.5),
        ("debounce", True),
        ("estimate_steps", 0),
    ],
)
def test_settings_out_of_range_are_refused_naming_the_setting(field, value):
    with pytest.raises(ConfigurationError, match=f"runtime setting {field}: expected"):
        RuntimeSettings(**{field: value})


def test_the_node_applier_shows_the_kernels_and_reads_scalar_ports():
    with Node(ROBOT) as node:
        applier = NodeApplier({ROBOT: node}, natives=natives(FAULT_AT))
        assert applier.sources() == {ROBOT: node.kernel}
        loaded = load()
        applier.start(ROBOT, "Sensor", loaded.database.module("Sensor"))
        node.run(until=0.1)
        assert applier.read(ROBOT, "Sensor.line") == 12.0  # bias 2, before the fault
        with pytest.raises(ApplyError, match=r"read Sensor\.nope on rover"):
            applier.read(ROBOT, "Sensor.nope")
        with pytest.raises(ApplyError, match="robot 'mars'"):
            applier.read("mars", "Sensor.line")


def test_an_event_that_quotes_a_node_is_shown_escaped_and_bounded():
    shown = line(Event(1.0, "link_failed", "node said \x1b]0;pwned\x07\r\nforged" + "A" * 9000))
    assert shown.isprintable() and "\\x1b]0;pwned\\x07\\r\\nforged" in shown
    assert len(shown) < MAX_EVENT + 100 and shown.endswith("more characters)")
