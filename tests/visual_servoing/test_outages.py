"""The outage scenarios: the rotation robot's node is lost while its camera serves the
HexManipulator's task (a coalition after the blackout of the HexManipulator's cameras), killed or
cut off, and the task moves back onto the HexManipulator; in rejoin the node restarts from its
flash file and is used again. In process the node is switched off; across processes it really is
killed (SIGKILL, on its own clock: in lock-step time the same quantum on every run), its link
really cut (a relay), and it really restarts on its port; both end alike."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import pytest

from application.launch import run_processes
from application.records import Outcome
from application.report import summary
from visual_servoing.declaration import APPLICATION
from visual_servoing.experiment.scenarios import KILL_AT

QUANTUM = APPLICATION.quantum

COALITION = "{CamReader@rotation, SSD, TrajGen, HexMan}"
BACK_HOME = "{CamReader, SSD, TrajGen, HexMan}"
FINAL = {
    "node-outage": BACK_HOME,
    "link-cut": BACK_HOME,
    "rejoin": "{CamReader, SSD@rotation, TrajGen, HexMan}",
}
LOOK = 0.1
"""The runtime's decision period: a loss is declared at the first look after it."""


def in_process(result: Outcome) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The summary and the events of a scenario's run in process."""
    return summary(APPLICATION, result), [event.as_dict() for event in result.log]


def of_kind(events: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [event for event in events if event["kind"] == kind]


def check(name: str, got: dict[str, Any], events: list[dict[str, Any]]) -> None:
    """What every run of scenario `name` must show: the coalition, the loss at the first look
    after the outage, the task moved back at once (and recovered), the end as expected."""
    first, moved, *later = got["reconfigurations"]
    assert first["chosen"] == COALITION
    (lost,) = of_kind(events, "node_lost")
    assert lost["data"]["robot"] == "rotation"
    assert KILL_AT < lost["time"] <= KILL_AT + LOOK + 1e-6
    assert moved["detected_at"] == pytest.approx(lost["time"])
    assert moved["located"] == "CamReader" and moved["chosen"] == BACK_HOME
    assert moved["applied_at"] == pytest.approx(lost["time"])
    assert moved["recovered_at"] is not None
    assert got["final"] == FINAL[name] and got["stopped_at"] is None
    rejoined = of_kind(events, "node_rejoined")
    if APPLICATION.scenario(name).outage.back is None:  # type: ignore[union-attr]
        assert rejoined == [] and later == []
        return
    (back,) = of_kind(events, "node_back")
    (again,) = rejoined
    assert back["time"] < again["time"] <= back["time"] + 1.0 + 1e-6  # the next try
    if name == "rejoin":
        (used,) = later
        assert used["located"] == "SSD" and used["chosen"] == FINAL[name]
        assert used["recovered_at"] is not None


@pytest.mark.parametrize("name", sorted(FINAL))
def test_in_process_the_lost_node_s_camera_is_replaced_at_once(
    name, scenario_outcome: Callable[[str], Outcome]
) -> None:
    got, events = in_process(scenario_outcome(name))
    check(name, got, events)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FINAL))
def test_across_processes_the_node_is_really_lost_and_the_run_ends_as_in_process(
    name, tmp_path, scenario_outcome: Callable[[str], Outcome]
) -> None:
    expected, _ = in_process(scenario_outcome(name))
    got = run_processes(APPLICATION, APPLICATION.scenario(name), tmp_path / "processes")
    events = json.loads((tmp_path / "processes" / "report.json").read_text())["events"]
    check(name, got, events)
    (lost,) = of_kind(events, "node_lost")
    if name == "link-cut":
        assert got["ended"] == {}  # the node lived on; only its link went down
        (again,) = of_kind(events, "node_rejoined")
        assert again["data"]["pbos"]["CamReader"] == "ON"  # it ran on, cut off
    else:
        assert got["ended"] == {"rotation": -9}  # SIGKILL
        assert "ADVANCE to 7.01 s" in lost["message"]  # the quantum it died in
    if name == "rejoin":
        first, again = (
            (tmp_path / "processes" / log).read_text().splitlines()[0]
            for log in ("rotation.log", "rotation-2.log")
        )
        assert again.startswith("listening on tcp-listen://127.0.0.1:")
        assert again == first  # on the port the system picked for its first run
    pairs = zip(got["reconfigurations"], expected["reconfigurations"], strict=True)
    for index, (mine, theirs) in enumerate(pairs):
        assert mine["chosen"] == theirs["chosen"]
        # The blackout's and the outage's repairs come at the same looks both ways. The frames
        # differ by a few pixels (docs/experiment.md), so by 11 s the task's turns may fall a
        # look or two apart, and a turn that meets the battery's sag counts to its debounce.
        slack = QUANTUM if index < 2 else APPLICATION.settings.decision_period + QUANTUM
        for key in ("detected_at", "applied_at"):
            assert mine[key] == pytest.approx(theirs[key], abs=slack), key
