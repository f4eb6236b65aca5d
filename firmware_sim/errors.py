"""The exception tree of firmware_sim.

Every failure of an emulated node (its flash, loader, guest CPU, kernel services, links to the
wires and servos) raises a subclass of `FirmwareSimError`, so the node's command catches one
class. Each class also inherits the builtin it refines where one fits.

Tree::

    FirmwareSimError                   the root: every error firmware_sim raises
"""

from __future__ import annotations


class FirmwareSimError(Exception):
    """Base class of every error firmware_sim raises."""
