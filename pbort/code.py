"""The contract between the kernel and the code of a module.

The kernel (lifecycle, state-variable table, scheduler, evaluators, estimators) never runs module
code itself. It asks a `ModuleCode` for `Instance`s, each with its own state and port buffers: one
instance is the executor, others serve the estimator in shadow runs. Two back ends implement the
contract: native Python classes (`pbort.native`) and guest code on the emulated CPU
(`firmware_sim`). The kernel and ReFrESH treat both alike.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import Protocol

from pbort.ports import PortSpec, PortValue


class Method(Enum):
    """The methods of a PBO (Stewart) plus the two of an E-PBO."""

    INIT = "init"
    ON = "on"
    CYCLE = "cycle"
    OFF = "off"
    KILL = "kill"
    ERROR = "error"
    CLEAR = "clear"
    EVALUATE = "evaluate"
    ESTIMATE = "estimate"


class Role(Enum):
    """What an instance is for: the running executor, or an estimator in a shadow run."""

    EXECUTOR = "executor"
    ESTIMATOR = "estimator"


class PerformanceKind(IntEnum):
    """Kinds of performance value an evaluator or estimator reports (values match the C ABI)."""

    FUNCTIONAL = 0
    NON_FUNCTIONAL = 1


@dataclass(frozen=True)
class CallResult:
    """How one method call went.

    `status` is the method's return value (0 = ok, negative = the method reports an error).
    `fault` is set when the call was stopped by the node instead (a protection fault, the
    watchdog, an illegal instruction); the kernel then puts the PBO into its error state.
    `duration` is the virtual time the call took, in seconds; `instructions` the guest
    instructions executed (0 for native code). `where` names the function and source line a
    failing status came from (``gain_on (gain.c:57)``), when the code knows its source; a fault
    names its own place in its text.
    """

    status: int = 0
    fault: str | None = None
    duration: float = 0.0
    instructions: int = 0
    where: str | None = None

    @property
    def ok(self) -> bool:
        """True when the method returned 0 and the node did not stop it."""
        return self.fault is None and self.status == 0


@dataclass(frozen=True)
class Services:
    """What the kernel offers an instance while it runs: performance reports, time, log.

    `report(kind, index, value)` files a performance value (value in natural units, e.g. mW);
    `now()` is the node's current time in seconds; `log(text)` records a line from the module.
    """

    report: Callable[[PerformanceKind, int, float], None]
    now: Callable[[], float]
    log: Callable[[str], None]


class Instance(Protocol):
    """One instance of a module's code, with its own state and port buffers."""

    def put(self, port: str, value: PortValue) -> None:
        """Set the value of an input, constant or resource port before a call."""

    def get(self, port: str) -> PortValue:
        """The value of a port (outputs after a call)."""

    def call(self, method: Method) -> CallResult:
        """Run one method; an absent method counts as returning 0 in no time."""

    def release(self) -> None:
        """Free the instance's memory; it is not used again."""


class ModuleCode(Protocol):
    """The code of one module, native or guest: its name, ports, and a factory of instances."""

    @property
    def name(self) -> str:
        """The module's name, unique on a node."""

    @property
    def ports(self) -> tuple[PortSpec, ...]:
        """The module's ports, in descriptor order."""

    def implements(self, method: Method) -> bool:
        """True when the module has its own code for `method`."""

    def instantiate(self, role: Role, services: Services) -> Instance:
        """A new instance with zeroed state and ports."""
