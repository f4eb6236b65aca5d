"""The rate rule: the Decider must not look more often than the metrics it reads are reported.

A module reports a task metric from its evaluator once per period of its PBO, at the database's
`frequency` (10 Hz when a module gives none). A Decider looking faster reads the same report
several times: a violation counts towards the debounce once per look, not once per evidence, and a
stale report hides a fault or makes one. The runtime therefore refuses, when it is made, a database
in which a module that may fill a metric's slot (a module of the metric's schema, or the last
module of a combo the Generator may build in that slot) runs slower than the Decider looks. A
rule checked once up front, before anything is deployed, rather than at each switch: a
configuration chosen by a repair must not be refused halfway through one.
"""

from __future__ import annotations

from refresh.database import Module, ModuleDatabase
from refresh.errors import RateError
from refresh.generator import DEFAULT_MAX_MODULES, combos
from refresh.task import TaskSpec


def check_rates(database: ModuleDatabase, task: TaskSpec, decision_period: float) -> None:
    """Refuse a module that may fill a metric's slot and runs slower than 1 / `decision_period`."""
    looks = 1.0 / decision_period
    for metric in task.metrics.values():
        for module in _metric_sources(database, metric.schema):
            if module.frequency < looks * (1 - 1e-9):
                raise RateError(
                    f"module {module.name!r} reports metric {metric.name!r} at "
                    f"{module.frequency:g} Hz (its frequency; 10 Hz when the database gives "
                    f"none), but the Decider "
                    f"looks every {decision_period:g} s ({looks:g} Hz): expected a frequency of "
                    f"at least {looks:g} Hz, or a decision period of at least "
                    f"{1.0 / module.frequency:g} s"
                )


def _metric_sources(database: ModuleDatabase, schema: str) -> list[Module]:
    """Every module whose reports may fill `schema`'s slot, in database order."""
    plain = list(database.schemas[schema].modules)
    found = {module.name: module for module in plain}
    for module in plain:
        for combo in combos([module], database, DEFAULT_MAX_MODULES):
            found.setdefault(combo[-1].name, combo[-1])
    return list(found.values())
