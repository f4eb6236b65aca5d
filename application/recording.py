"""The plant of a run: the application's world, plus what the framework itself injects and
records (`RunPlant`).

It hands the runtime's session the application's plant (its natives, live inputs, looks, own
events) and adds the scenario's faults that are the framework's (a power drop, a node's outage,
each at its time and logged as an event), logs the scenario at the start, and records a sample
of the world after every sample period while a configuration runs. Outages are carried out by
the side the run is on (`Outages`): in process a node is switched off and on; across processes
a link is cut at a relay, a killed node restarts, and the manager waits for either to be back.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

from application.hardware import estimator_natives
from application.plant import WorldPlant
from application.records import Outcome, Sample
from application.scenario import Outage, PowerDrop
from pbort.code import ModuleCode
from refresh.appliers.base import Inventory
from refresh.configuration import Configuration
from refresh.manager.plant import Event, Plant, View


class Outages(Protocol):
    """How the side a run is on makes a node's outage happen and end."""

    def lose(self, view: View, outage: Outage) -> None:
        """The outage strikes its robot's node."""

    def restore(self, view: View, outage: Outage) -> None:
        """The outage ends: the node is back (restarted, or reachable again)."""


class RunPlant(Plant):
    """`plant` for a run of its scenario, recording into `outcome`; `outages` carries out the
    scenario's outage; `supervise` is called at each look (across processes, the launcher's
    watch over the processes it started: it raises if one ended that should not have)."""

    def __init__(
        self,
        plant: WorldPlant,
        outcome: Outcome,
        outages: Outages,
        supervise: Callable[[], None] = lambda: None,
    ) -> None:
        self.plant = plant
        self.outcome = outcome
        self.outages = outages
        self.supervise = supervise
        self.sample_period = plant.sample_period

    def natives(self) -> Mapping[str, ModuleCode]:
        """The plant's natives and the hardware modules' E-PBOs, which the manager's
        estimators run in shadow on models of the robots' fabrics."""
        setting = self.plant.setting
        return self.plant.natives() | estimator_natives(setting.application, setting.database)

    def events(self) -> list[Event]:
        scenario = self.outcome.scenario
        events = list(self.plant.events())
        if scenario.power_drop is not None:
            drop = scenario.power_drop
            events.append((drop.time, lambda view: _drop_power(view, drop)))
        outage = scenario.outage
        if outage is not None:
            events.append((outage.time, lambda view: self._lose(view, outage)))
            if outage.back is not None:
                events.append((outage.back, lambda view: self._restore(view, outage)))
        return events

    def start(self, view: View) -> None:
        scenario = self.outcome.scenario
        view.runtime.log.record("scenario", scenario.title, name=scenario.name)
        self.plant.start(view)

    def inputs(self, view: View) -> Mapping[str, object]:
        return self.plant.inputs(view)

    def look(self, view: View) -> None:
        self.supervise()
        self.plant.look(view)
        if view.running:
            self.outcome.samples.append(Sample(view.now, dict(self.plant.sample(view))))

    def switched(self, view: View, configuration: Configuration) -> None:
        self.plant.switched(view, configuration)

    def rejoined(self, view: View, robot: str, inventory: Inventory) -> None:
        self.plant.rejoined(view, robot, inventory)

    def _lose(self, view: View, outage: Outage) -> None:
        killed = "killed" if outage.kind == "kill" else "cut off"
        view.runtime.log.record(
            "outage",
            f"robot {outage.robot}: its node is {killed}",
            robot=outage.robot,
            outage=outage.kind,
        )
        self.outages.lose(view, outage)

    def _restore(self, view: View, outage: Outage) -> None:
        self.outages.restore(view, outage)
        how = "restarted from its flash file" if outage.kind == "kill" else "reachable again"
        view.runtime.log.record(
            "node_back", f"robot {outage.robot}: its node {how}", robot=outage.robot,
            outage=outage.kind,
        )  # fmt: skip


def _drop_power(view: View, drop: PowerDrop) -> None:
    view.runtime.database.set_capacity(drop.robot, "power", drop.capacity)
    view.runtime.log.record(
        "power_drop",
        f"robot {drop.robot}: power capacity down to {drop.capacity:g}",
        robot=drop.robot,
        capacity=drop.capacity,
    )
