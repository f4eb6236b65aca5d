"""A managed run: the runtime over an applier, on a time mode, with the caller's plant.

`Session` is the one loop every managed run goes through, whatever runs the robots (nodes in
this process advanced together, node processes in lock-step or real time): it deploys the task,
then lets the world run one sample period at a time (the plant's, else the decision period),
fires the plant's events when their time has come, lets the plant look after each period, and
steps the runtime once per decision period. Events recorded by the runtime go to the event
stream before each period, so a user sees them within a period of when they happened.

A migration over a modelled wire takes time in the run: the applier's `wait` is the session's
`wait`, which lets the world run on the same way (sampled, stepped: the old configuration keeps
working meanwhile, and the Decider keeps judging it, without starting a second decision).

Samples are due on a grid of sample periods from the deployment, not a period after each
sample's work: in real time that work (a read, the plant's look, a decision step) would stretch
every period. How late a sample came (but for a decision's own time) is the manager's slip,
which the runtime hears as `host_slip` and judges as a node's (docs/refresh.md, "Real time").
"""

from __future__ import annotations

import math
from collections.abc import Callable

from refresh.configuration import Configuration
from refresh.errors import ConfigurationError
from refresh.manager.plant import Event, Plant, View
from refresh.manager.time_modes import TimeMode
from refresh.runtime import Runtime

EPSILON = 1e-9
"""Seconds: two times closer than this are one (sums of periods are not exact)."""


class Session:
    """`runtime` run on `time` with `plant`; `flush()` writes the events recorded so far and
    `progress(now)` hears the run's time after every sample period."""

    def __init__(
        self,
        runtime: Runtime,
        time: TimeMode,
        plant: Plant,
        *,
        flush: Callable[[], None] = lambda: None,
        progress: Callable[[float], None] = lambda now: None,
    ) -> None:
        self.runtime = runtime
        self.time = time
        self.plant = plant
        self.flush = flush
        self.progress = progress
        self.view = View(runtime, runtime.applier)
        decision = runtime.settings.decision_period
        self.period = plant.sample_period or decision
        looks = decision / self.period
        if not (math.isfinite(looks) and round(looks) >= 1 and abs(looks - round(looks)) < 1e-6):
            raise ConfigurationError(
                f"sample period {self.period:g} s: expected a whole fraction of the decision "
                f"period {decision:g} s, got {looks:g} samples per decision"
            )
        self.per_decision = round(looks)
        self._samples = 0
        self._events: list[Event] = sorted(plant.events(), key=lambda event: event[0])
        runtime.on_switch = self._switched
        runtime.on_rejoin = lambda robot, inventory: plant.rejoined(self.view, robot, inventory)
        runtime.applier.wait = self.wait
        runtime.host_slip = self._lateness
        self._due = 0.0  # the run's time the next sample is due, on the sample grid
        self._late = 0.0  # the worst lateness of a sample since `_lateness` was asked
        self._excused = False  # the last period decided: its overrun is no slip

    def run(self, until: float) -> None:
        """Start the plant, deploy the task and run the world to `until` seconds (math.inf:
        until interrupted)."""
        self.plant.start(self.view)
        self.runtime.deploy()
        self.flush()
        self._due = self.time.clock() + self.period  # in real time deploying took time
        self._run_to(until)
        self.flush()

    def wait(self, seconds: float) -> None:
        """Let the world run `seconds` further, as the run does (a migration's time)."""
        self._run_to(self.time.clock() + seconds)

    def _run_to(self, until: float) -> None:
        while until - self.time.clock() > EPSILON:
            self._fire_due()
            self.flush()
            self._advance(until)
            self._samples += 1
            self.plant.look(self.view)
            self.progress(self.time.clock())
            if self._samples % self.per_decision == 0:
                decided = len(self.runtime.history.reconfigurations)
                self.runtime.step()
                self._excused = len(self.runtime.history.reconfigurations) != decided

    def _advance(self, until: float) -> None:
        """Let the world run to the next sample, due on the sample grid (not a period after
        this one's work: in real time that work would stretch every period), and note how late
        it came. A period whose work overran it is late by the overrun, unless it was a
        decision's (a migration's time is the decision's, not a slip); the grid starts again
        from now, rather than run the samples missed in a burst."""
        before = self.time.clock()
        due = min(until, self._due)
        if due <= before + EPSILON:  # only in real time: the clocks of lock-step add up
            if not (self._excused or self.runtime.deciding):
                self._late = max(self._late, before - due)
            due = min(until, before + EPSILON)
        self.time.advance(due - before)
        now = self.time.clock()
        if now <= before:
            raise ConfigurationError(
                f"advance: expected the run's clock to move on from {before:g} s, got {now:g} s"
            )
        self._late = max(self._late, now - due)
        self._due = due + self.period
        self._excused = False

    def _lateness(self) -> float:
        """How late the samples since the last call came, at worst (s): the manager's own slip
        behind real time (0 on a virtual clock)."""
        late, self._late = self._late, 0.0
        return late

    def _switched(self, configuration: Configuration) -> None:
        """An event for each configuration once it runs (``deployed`` for the first, ``switch``
        for a repair's); then the plant hears of it."""
        first = not self.runtime.history.configurations
        self.runtime.log.record(
            "deployed" if first else "switch",
            f"running {configuration.label()}",
            configuration=configuration.label(),
        )
        self.plant.switched(self.view, configuration)

    def _fire_due(self) -> None:
        """Run the plant's events whose time has come."""
        while self._events and self._events[0][0] <= self.time.clock() + EPSILON:
            _at, event = self._events.pop(0)
            event(self.view)
