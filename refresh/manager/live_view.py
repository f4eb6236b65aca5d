"""What the manager serves live in Foxglove (``manage --foxglove HOST:PORT``): ReFrESH's events
on ``/events`` (the channel and schema of an application's ``report.mcap``), the configuration
that runs on ``/configuration`` (at the deployment, each switch and a safe stop), and every
report of each robot's node on ``/reports/ROBOT`` (leftover power, real-time slip, missed
releases, evaluator outputs ``PBO:F0``, watched ports), on the run's clock.
"""

from __future__ import annotations

from collections.abc import Iterable

from hexmigrate.transfer.control import Number
from pbort.trace.live import LiveView
from refresh.events import EVENT_FIELDS, Event

EVENTS, CONFIGURATION = "/events", "/configuration"
REPORT_FIELDS = {
    "leftover": {"type": "number", "description": "the node's leftover power, 0-100"},
    "slip": {"type": "number", "description": "its largest slip behind real time, ms"},
    "missed": {"type": "integer", "description": "releases it missed on slips"},
}
"""A report's fields that every node sends; the others (``PBO:F0``, ports) are numbers too."""
CONFIGURATION_FIELDS = {
    "configuration": {"type": ["string", "null"], "description": "what runs (null: nothing)"},
    "kind": {"type": "string", "description": "deployed, switch or stopped"},
}
RUNNING = {"deployed", "switch", "stopped"}
"""The event kinds that change what runs."""


def report_topic(robot: str) -> str:
    """The channel of a robot's node's reports."""
    return f"/reports/{robot}"


class ManagerView:
    """The manager's channels on `view`, for `robots`."""

    def __init__(self, view: LiveView, robots: Iterable[str]) -> None:
        self.view = view
        view.channel(EVENTS, "ReFrESH event", EVENT_FIELDS)
        view.channel(CONFIGURATION, "ReFrESH configuration", CONFIGURATION_FIELDS)
        for robot in robots:
            view.channel(report_topic(robot), "node report", REPORT_FIELDS, open_ended=True)

    def event(self, event: Event) -> None:
        """An event; one that changes what runs also on ``/configuration``."""
        self.view.message(
            EVENTS, event.time, {k: v for k, v in event.as_dict().items() if k != "time"}
        )
        if event.kind in RUNNING:
            running = event.data.get("configuration") if event.kind != "stopped" else None
            self.view.message(
                CONFIGURATION, event.time, {"configuration": running, "kind": event.kind}
            )

    def report(self, robot: str, clock: float, values: tuple[tuple[str, Number], ...]) -> None:
        """A report of `robot`'s node, at the node's `clock`."""
        self.view.message(report_topic(robot), clock, dict(values))
