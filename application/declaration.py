"""An application: what a task on ReFrESH is, declared once, from which the framework makes
everything else (its commands, runs in process and across processes, records, reports, campaign).

An application declares its module database and scenarios, the native modules of its robots'
firmware and the guest modules it builds, its world (`plant`: the base `WorldPlant` when the
task's body is all in its modules), what a run samples of the world (`observe`, described by
`sample_fields`, drawn by `figure`) and what the estimators start from at a decision
(`live_inputs`), the runtime's settings and the few figures of its robots (how often the world
is sampled, how finely in-process nodes are stepped together, the wire between the robots, the
wire migrations cross, the instruction budget of a method call).
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from application.plant import WorldPlant
from application.scenario import Scenario, scenario_named
from firmware_sim.core.guest import DEFAULT_BUDGET
from pbort.native import NativePBO
from pbort.ports import PortSpec
from refresh.manager.plant import View
from refresh.runtime import RuntimeSettings

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from application.records import Outcome


@dataclass(frozen=True)
class SampleField:
    """One value of a sample: its name, what it is (with its unit), and whether it is a whole
    number."""

    name: str
    description: str
    integer: bool = False


@dataclass(frozen=True)
class Figure:
    """The run's figure: sample field `field` over time, labelled `label` (with its unit), the
    task's threshold on it drawn at plus and minus `limit`; written as `file`. `back(sample)`
    says whether a sample shows the task back within its threshold (the report times a recovery
    from the first such sample after a switch; None: from when the runtime saw P_T = 1 again);
    `panel(axes, outcome)` draws a second panel beside it; `beside` is another sample field
    drawn lighter on the same axes (the true value of a reported one), labelled
    `beside_label`."""

    field: str
    label: str
    limit: float
    file: str
    back: Callable[[Mapping[str, float]], bool] | None = None
    panel: Callable[[Axes, Outcome], None] | None = None
    beside: str | None = None
    beside_label: str = ""


@dataclass(frozen=True)
class Campaign:
    """What a campaign of the application draws: the scenario families it draws from (names of
    the application's scenarios), `draw(rng, families, location)` one run's parameters (with
    ``fault_type``, ``fault_at`` and ``truth``: `campaign.record`), and `scenario_of(drawn,
    index)` the scenario that runs them."""

    families: Sequence[str]
    draw: Callable[[random.Random, Sequence[str], str | None], Mapping[str, Any]]
    scenario_of: Callable[[Mapping[str, Any], int], Scenario]


def _nothing(view: View) -> Mapping[str, float]:
    return {}


@dataclass(frozen=True)
class Application:
    """An application of the framework; see the module's docstring."""

    name: str
    """Its package, its command (``python -m NAME``) and its folders (``build/NAME``)."""
    summary: str
    """What the application is, in a paragraph: the start of its command's ``--help``."""
    database: Path
    scenarios: tuple[Scenario, ...]
    default_scenario: str
    natives: Mapping[str, type[NativePBO]] = field(default_factory=dict)
    """The native modules' classes by name (what the robots' firmware has built in)."""
    guests: Mapping[str, Path] = field(default_factory=dict)
    """Guest module name -> its C source, built into the HEX file the database names for it."""
    hardware: Mapping[str, tuple[PortSpec, PortSpec]] = field(default_factory=dict)
    """Hardware module name -> its E-PBO's input and output ports (`application.hardware`): the
    database says which functionalities of which robot's fabric compute it."""
    plant: type[WorldPlant] = WorldPlant
    observe: Callable[[View], Mapping[str, float]] = _nothing
    live_inputs: Callable[[View], Mapping[str, object]] = _nothing
    sample_fields: tuple[SampleField, ...] = ()
    figure: Figure | None = None
    settings: RuntimeSettings = field(default_factory=RuntimeSettings)
    sample_period: float = 0.1
    """Seconds between two samples of the world (a whole fraction of the decision period)."""
    step: float = 0.001
    """Seconds the robots' nodes advance together in process."""
    quantum: float = 0.01
    """The lock-step quantum across processes, by default."""
    link: tuple[str, float] = ("serial", 115_200.0)
    """What a port bridged between two robots crosses: a wire and its bit rate."""
    migration_wire: str | None = None
    """The wire a migration's time is modelled on (None: a migration takes no time)."""
    budget: int = DEFAULT_BUDGET
    """Guest instructions a method call may take, on the robots' nodes and the host."""
    listen: Mapping[str, str] = field(default_factory=dict)
    """Where a robot's node listens across processes, by robot (``pty``: a serial line, which
    migrations cross); the others on TCP."""
    report_period: float | None = None
    """Seconds between two reports of a node across processes (None: the manager's default)."""
    campaign: Campaign | None = None
    errors: tuple[type[Exception], ...] = ()
    """The application's own exception roots, which its command reports as one line too."""

    def scenario(self, name: str) -> Scenario:
        """The scenario called `name` (KeyError naming the known ones)."""
        return scenario_named(self.scenarios, name)

    @property
    def out(self) -> Path:
        """Where the application's runs are written by default."""
        return Path("build") / self.name
