"""The exception tree of the visual-servoing task and experiment.

Every refusal of this package raises a subclass of `ServoingError`, so a caller (the experiment's
command, a test) can catch one class; each class also inherits the builtin it refines. Messages
say what was expected and what came.

Tree::

    ServoingError
    ├── FrameError (ValueError)             a frame that is not a 2-D uint8 array of the shape
    │                                       expected
    ├── SceneError (ValueError)             scene or sprite parameters no frame can be drawn with
    ├── UnknownTargetError (KeyError)       a target name the scene does not have
    ├── FaultError (ValueError)             a fault's strength or time window, or a frame's time,
    │   │                                   out of range
    │   └── UnknownFaultError               a fault kind that is not one of FaultKind's
    ├── TaskSetupError (ValueError)         a task module asked for with parameters it cannot
    │                                       run with (a scene of another size, an unknown method)
    └── ExperimentError (RuntimeError)      the experiment's world that cannot be set up (a servo
                                            bus missing) or a run it cannot go on with (a
                                            restarted HexManipulator node)
"""

from __future__ import annotations


class ServoingError(Exception):
    """Base class of every error the visual-servoing package raises."""


class FrameError(ServoingError, ValueError):
    """A frame that is not a 2-D uint8 array, or not of the shape expected."""


class SceneError(ServoingError, ValueError):
    """Scene or sprite parameters no frame can be drawn with."""


class UnknownTargetError(ServoingError, KeyError):
    """A target name the scene does not have; the message lists those it has."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class FaultError(ServoingError, ValueError):
    """A camera fault out of range: its strength, its time window, or the time of a frame."""


class UnknownFaultError(FaultError):
    """A fault kind that is not one of FaultKind's."""


class TaskSetupError(ServoingError, ValueError):
    """A task module asked for with parameters it cannot run with."""


class ExperimentError(ServoingError, RuntimeError):
    """The experiment's world that cannot be set up, or a run it cannot go on with; the message
    says why."""
