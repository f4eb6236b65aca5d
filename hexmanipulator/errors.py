"""The exception tree of the HexManipulator.

Every refusal of the platform's code raises a subclass of `HexmanipulatorError`, so a caller (a
command, an experiment) can catch one class; each class also inherits the builtin it refines.
Messages say where (the file and key, the pose, the leg, the link) and what was expected.

Tree::

    HexmanipulatorError
    ├── GeometryError (ValueError)            a geometry file that is malformed or describes a
    │                                         platform that cannot be built (or driven on a bus)
    ├── UnreachablePoseError (ValueError)     a pose outside the workspace, or that a leg cannot
    │                                         reach within its joint limit
    ├── CrankAnglesError (ValueError)         crank angles that are not six finite numbers
    ├── ForwardKinematicsError (ArithmeticError)
    │                                         Newton's method found no pose for the crank angles
    └── ServoBusError (OSError)               the servo link failed; the message names it
        ├── ServoSilentError (TimeoutError)       a servo (or the controller) did not answer
        ├── BusOffError                           the host's CAN controller left the bus
        └── CableCutError                         the serial line is gone
"""

from __future__ import annotations


class HexmanipulatorError(Exception):
    """Base class of every error the HexManipulator's code raises."""


class GeometryError(HexmanipulatorError, ValueError):
    """A geometry file that is malformed or describes a platform that cannot be built."""


class UnreachablePoseError(HexmanipulatorError, ValueError):
    """The pose is outside the workspace or a leg cannot reach it."""


class CrankAnglesError(HexmanipulatorError, ValueError):
    """Crank angles that are not six finite numbers of degrees."""


class ForwardKinematicsError(HexmanipulatorError, ArithmeticError):
    """Newton's method found no pose for these crank angles."""


class ServoBusError(HexmanipulatorError, OSError):
    """The servo link failed; the message says why and where."""


class ServoSilentError(ServoBusError, TimeoutError):
    """A servo (or the controller) did not answer in time."""


class BusOffError(ServoBusError):
    """The host's CAN controller left the bus."""


class CableCutError(ServoBusError):
    """The serial line is gone (cable pulled, device unplugged, emulator closed)."""
