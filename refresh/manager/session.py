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

    def run(self, until: float) -> None:
        """Start the plant, deploy the task and run the world to `until` seconds (math.inf:
        until interrupted)."""
        self.plant.start(self.view)
        self.runtime.deploy()
        self.flush()
        self._run_to(until)
        self.flush()

    def wait(self, seconds: float) -> None:
        """Let the world run `seconds` further, as the run does (a migration's time)."""
        self._run_to(self.time.clock() + seconds)

    def _run_to(self, until: float) -> None:
        while (left := until - self.time.clock()) > EPSILON:
            self._fire_due()
            self.flush()
            before = self.time.clock()
            self.time.advance(min(self.period, left))
            if self.time.clock() <= before:
                raise ConfigurationError(
                    f"advance: expected the run's clock to move on from {before:g} s, got "
                    f"{self.time.clock():g} s"
                )
            self._samples += 1
            self.plant.look(self.view)
            self.progress(self.time.clock())
            if self._samples % self.per_decision == 0:
                self.runtime.step()

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
