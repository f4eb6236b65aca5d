"""refresh.runtime: ReFrESH's run loop for any task, on the caller's clock.

One concept per module:

============  ==========================================================================
``settings``  `RuntimeSettings`: decision period, debounce, settle, recovery hold, steps
``rates``     the rate rule: no metric module slower than the Decider looks
``history``   `Reconfiguration` and `History`: what the runtime did, for a report
``runtime``   `Runtime`: deploy, then decide and repair once per decision period, through an
              applier (`refresh.appliers`) and an estimator factory (`refresh.estimators`)
============  ==========================================================================
"""

from refresh.runtime.history import History, Reconfiguration
from refresh.runtime.runtime import Runtime
from refresh.runtime.settings import RuntimeSettings

__all__ = ["History", "Reconfiguration", "Runtime", "RuntimeSettings"]
