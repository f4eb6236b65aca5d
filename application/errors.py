"""The exception tree of the application framework.

Every refusal of the framework raises a subclass of `ApplicationError`, so an application's
command catches one class; each class also inherits the builtin it refines. Messages say what
was expected and what came.

Tree::

    ApplicationError
    ├── ScenarioError (ValueError)    a scenario that does not fit its application: a fault in a
    │                                 module the database does not have, or one without a
    │                                 fault_at constant, an outage of a robot it does not have
    ├── ApplicationSetupError (RuntimeError)
    │                                 a run that cannot be set up here: a guest module whose
    │                                 build failed, a plant device that cannot be opened
    └── RunError (RuntimeError)       a run that failed midway: a node that did not come back,
                                      a world that could not advance
"""

from __future__ import annotations


class ApplicationError(Exception):
    """Base class of every error the application framework raises."""


class ScenarioError(ApplicationError, ValueError):
    """A scenario that does not fit its application's database or robots."""


class ApplicationSetupError(ApplicationError, RuntimeError):
    """A run that cannot be set up on this machine; the message says why."""


class RunError(ApplicationError, RuntimeError):
    """A run that failed midway; the message says where and why."""
