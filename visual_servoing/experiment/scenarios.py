"""The scenarios: the paper's experiment, and faults beyond it.

A scenario names the module database, the faults each camera device suffers and when, and how
long the task runs. Every scenario starts from the task's preprogrammed configuration on the
HexManipulator robot; `expected` says what ReFrESH should end up doing, in words, for the report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from visual_servoing.image_faults import Fault, FaultKind

DATA = Path(__file__).resolve().parent
FAULT_AT = 4.0
"""When the fault strikes, seconds into the run (the paper injects noise at about 4 s)."""


@dataclass(frozen=True)
class Scenario:
    """What to run: `database` (a TOML file), camera faults by device, `duration` seconds."""

    name: str
    title: str
    expected: str
    database: Path = DATA / "paper.toml"
    faults: dict[str, tuple[Fault, ...]] = field(default_factory=dict)
    duration: float = 10.0
    fault_at: float = FAULT_AT


PAPER = Scenario(
    "paper",
    "noise injected into CamReader (the paper's section 6)",
    "CamReader located by Base Choice; {CamReader, Dehazer, SSD, TrajGen, HexMan} chosen; "
    "the Dehazer migrated and started; the task back within 30 pixels",
    faults={"CamReader": (Fault(FaultKind.SALT_PEPPER, 0.3, FAULT_AT),)},
)

SCENARIOS = {scenario.name: scenario for scenario in (PAPER,)}
