"""refresh.manager: ReFrESH managing a task whose robots' nodes run in other processes.

``python -m refresh manage`` is made of these pieces, each usable on its own (a program that
runs its own robots across processes builds the same manager from them):

================  ===========================================================================
``codes``         `host_codes` and `host_estimators`: the manager's host holds every module's
                  code (the guest images the database names, the natives) to estimate with
``time_modes``    the two time modes: `LockStep` (a `TimeMaster` grants the nodes quanta) and
                  `RealTime` (the host's monotonic clock); each checks the nodes run in it
``event_stream``  `EventStream`: each event printed and written as a JSON line as it comes
``manager``       `ManagerConfig` and `manage`: open the nodes, deploy, decide and repair
================  ===========================================================================
"""

from refresh.manager.event_stream import EventStream
from refresh.manager.manager import ManagerConfig, manage
from refresh.manager.time_modes import LockStep, RealTime, TimeMode

__all__ = [
    "EventStream",
    "LockStep",
    "ManagerConfig",
    "RealTime",
    "TimeMode",
    "host_codes",
    "host_estimators",
    "manage",
]
