"""The exception tree of the patrol task.

Every refusal of this package raises a subclass of `PatrolError`, so a caller (the command, a
test) can catch one class; each class also inherits the builtin it refines. Messages say what was
expected and what came.

Tree::

    PatrolError
    ├── ScenarioError (ValueError)      a scenario asking for a fault in a module the database
    │                                   does not have, or one without a fault_at constant
    └── PatrolSetupError (RuntimeError) a patrol that cannot be set up here (a guest module's
                                        build failed)
"""

from __future__ import annotations


class PatrolError(Exception):
    """Base class of every error the patrol package raises."""


class ScenarioError(PatrolError, ValueError):
    """A scenario that does not fit the module database."""


class PatrolSetupError(PatrolError, RuntimeError):
    """A patrol that cannot be set up on this machine; the message says why."""
