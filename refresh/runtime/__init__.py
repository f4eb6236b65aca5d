"""refresh.runtime: ReFrESH's run loop for any task, on the caller's clock.

One concept per module:

==============  ==========================================================================
``settings``    `RuntimeSettings`: decision period, debounce, settle, recovery hold, steps
``applier``     `RuntimeApplier`: the Maintainer's `Applier` plus `sources()` and `read()`
``estimators``  `EstimatorFactory`, and `HostEstimators` on the manager's host kernel
``rates``       the rate rule: no metric module slower than the Decider looks
``history``     `Reconfiguration` and `History`: what the runtime did, for a report
``runtime``     `Runtime`: deploy, then decide and repair once per decision period
==============  ==========================================================================
"""

from refresh.runtime.applier import RuntimeApplier
from refresh.runtime.estimators import EstimatorFactory, HostEstimators
from refresh.runtime.history import History, Reconfiguration
from refresh.runtime.runtime import Runtime
from refresh.runtime.settings import RuntimeSettings

__all__ = [
    "EstimatorFactory",
    "History",
    "HostEstimators",
    "Reconfiguration",
    "Runtime",
    "RuntimeApplier",
    "RuntimeSettings",
]
