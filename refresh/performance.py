"""The performance functions of section 3.2, equations (1)-(5).

- (1) P_NF: one binary term per (robot, resource) of R, the resources of the robots the
  configuration places modules on: what is left of the capacity after the modules placed there
  exceeds the robot's reserve. A robot the configuration does not use is not judged (a sagging
  battery or a dead node elsewhere does not fail it); a robot it uses whose node is lost
  (`ModuleDatabase.lost`) has one term instead, ``node@robot``, which is 0: its modules count as
  failed.
  A robot with an FPGA fabric has one more term, ``fabric@robot``: no slot of its fabric is
  claimed by two hardware modules (a node's free slots bound what fits).
- (2) P_F: one binary term per task metric: the value is on the good side of its threshold.
- (3) P_T: the product of all terms.
- (4) Util(C) = alpha * sum_k Util_NF_k + (1 - alpha) * sum_j Util_F_j, where Util_NF_k is the use
  of resource k summed over every module of C (equation (10)) and Util_F_j the metric's cost.
- (5) the best configuration: the argmin of Util among those with P_T = 1.

Resource use comes from the database's declared needs (the Locator and Generator judge
configurations that are not running) or from the evaluators' reports (the Decider); functional
values come from estimators or evaluators. These functions do not care which.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TypeVar

from refresh.configuration import Chain, Configuration
from refresh.database import Module, ModuleDatabase
from refresh.task import TaskSpec

Usage = dict[tuple[str, str], float]
"""Resource use per (robot, resource)."""

NODE = "node"
"""The term of equation (1) a lost robot has instead of its resources' terms: always 0."""
FABRIC = "fabric"
"""The term of equation (1) of a robot's fabric: 1 when no slot is claimed twice."""
SLOT = "fabric.slot"
"""A slot's claims in a `Usage`, ``fabric.slot2`` (no resource can be named so: names have no
'.'); they count in the fabric's term, not in Util."""

T = TypeVar("T")


@dataclass(frozen=True)
class Assessment:
    """Every term of equations (1)-(4) for one configuration."""

    nonfunctional: Mapping[tuple[str, str], int]
    functional: Mapping[str, int]
    values: Mapping[str, float | None]
    usage: Mapping[tuple[str, str], float]
    util_nf: Mapping[str, float]
    util_f: Mapping[str, float]
    util: float

    @property
    def p_t(self) -> int:
        """Equation (3): 1 when every non-functional and functional term is 1."""
        terms = (*self.nonfunctional.values(), *self.functional.values())
        return int(all(terms))

    def failing(self) -> list[str]:
        """The terms that are 0, for the event log: ``power@hexmanipulator``, ``diff``."""
        return [f"{res}@{robot}" for (robot, res), ok in self.nonfunctional.items() if not ok] + [
            name for name, ok in self.functional.items() if not ok
        ]


def usage(configuration: Configuration, database: ModuleDatabase) -> Usage:
    """Declared resource use of every module of the configuration, per robot and resource."""
    used: Usage = {}
    for placement in configuration.placements:
        _add(used, placement.robot, _needs(database.module(placement.module)), 1.0)
    return used


def usage_replaced(base: Usage, old: Chain, new: Chain, database: ModuleDatabase) -> Usage:
    """`base` with the chain `old` taken out and `new` put in: one slot's change, without summing
    the whole configuration again (the Locator does this for every test case)."""
    used = dict(base)
    for placement in old:
        _add(used, placement.robot, _needs(database.module(placement.module)), -1.0)
    for placement in new:
        _add(used, placement.robot, _needs(database.module(placement.module)), 1.0)
    return used


def _needs(module: Module) -> Mapping[str, float]:
    """What a module uses of its robot: its declared needs, and the fabric slots a hardware
    module claims."""
    if module.hardware is None:
        return module.needs
    return {**module.needs, **{f"{SLOT}{slot}": 1.0 for slot in module.hardware.slots}}


def _add(used: Usage, robot: str, needs: Mapping[str, float], sign: float) -> None:
    """Add (`sign` 1) or take out (-1) one module's needs on `robot`."""
    for resource, amount in needs.items():
        used[robot, resource] = used.get((robot, resource), 0.0) + sign * amount


def assess(
    used: Mapping[tuple[str, str], float],
    values: Mapping[str, float | None],
    task: TaskSpec,
    database: ModuleDatabase,
    robots: Iterable[str] | None = None,
) -> Assessment:
    """Equations (1)-(4) for resource use `used` and functional `values` (metric -> value),
    judging the resources of `robots`, those the configuration places modules on
    (`Configuration.robots`; None: every robot of the database)."""
    judged = set(database.robots if robots is None else robots)
    nonfunctional = _nonfunctional(used, judged, database)
    util_nf: dict[str, float] = {}
    for (_, name), amount in used.items():
        if not name.startswith(SLOT):
            util_nf[name] = util_nf.get(name, 0.0) + amount
    metrics = task.metrics.values()
    functional = {m.name: int(m.satisfied(values.get(m.name))) for m in metrics}
    util_f = {m.name: m.cost(values.get(m.name)) for m in metrics}
    util = task.alpha * sum(util_nf.values()) + (1.0 - task.alpha) * sum(util_f.values())
    return Assessment(
        nonfunctional=nonfunctional,
        functional=functional,
        values=dict(values),
        usage=dict(used),
        util_nf=util_nf,
        util_f=util_f,
        util=util,
    )


def _nonfunctional(
    used: Mapping[tuple[str, str], float], judged: set[str], database: ModuleDatabase
) -> dict[tuple[str, str], int]:
    """Equation (1)'s terms for the robots `judged`, in database order."""
    terms: dict[tuple[str, str], int] = {}
    for robot in database.robots.values():
        if robot.name not in judged:
            continue
        if robot.name in database.lost:
            terms[robot.name, NODE] = 0
            continue
        for name, resource in robot.resources.items():
            terms[robot.name, name] = int(resource.satisfied(used.get((robot.name, name), 0.0)))
        if robot.fabric is not None:
            claims = (
                used.get((robot.name, f"{SLOT}{slot}"), 0.0)
                for slot in range(len(robot.fabric.slots))
            )
            terms[robot.name, FABRIC] = int(all(claim <= 1.0 for claim in claims))
    return terms


def best(assessed: Iterable[tuple[T, Assessment]]) -> tuple[T, Assessment] | None:
    """Equation (5): the item of least Util among those with P_T = 1 (the first on a tie)."""
    chosen: tuple[T, Assessment] | None = None
    for item, assessment in assessed:
        if assessment.p_t and (chosen is None or assessment.util < chosen[1].util):
            chosen = (item, assessment)
    return chosen
