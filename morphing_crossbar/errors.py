"""The exception tree of the Morphing Crossbar package.

Bitstream errors carry the same numeric ``code`` the wrapper reports on ``cfg_error_code`` when it
refuses a frame, so a test can check that the hardware and the model refuse for the same reason.
"""

from __future__ import annotations


class CrossbarError(Exception):
    """Base class of every error this package raises."""


class FabricParameterError(CrossbarError, ValueError):
    """Fabric parameters the hardware cannot be built with (N, widths, cluster size, kinds)."""


class RouteError(CrossbarError, ValueError):
    """A routing the fabric cannot carry: unreachable source, two consumers, or a cycle."""


class BitstreamError(CrossbarError, ValueError):
    """A partial bitstream the wrapper refuses; ``code`` is the wrapper's error code."""

    code = 0


class CrcError(BitstreamError):
    """The frame's CRC-8 does not match its contents (a corrupt bitstream)."""

    code = 1


class LengthError(BitstreamError):
    """The frame has the wrong number of bits."""

    code = 2


class MagicError(BitstreamError):
    """The frame does not start with the magic nibble 0xA."""

    code = 3


class SlotMismatchError(BitstreamError):
    """The frame was packed for another slot than the one it was sent to."""

    code = 4


class SelectorRangeError(BitstreamError):
    """A selector names a source the slot does not have."""

    code = 5


class RefusedRouteError(BitstreamError):
    """The slot would take one source twice, or feed its functionality from itself."""

    code = 6


class BitstreamImageError(CrossbarError, ValueError):
    """A HEX image that does not hold a crossbar bitstream (wrong region, size or header)."""
