"""The exception tree of the Morphing Crossbar package.

Every refusal of this package raises a subclass of `CrossbarError`, so a caller (the pack command,
a node's reconfiguration port) can catch one class; each class also inherits the builtin it
refines. Bitstream errors carry the same numeric ``code`` the wrapper reports on
``cfg_error_code`` when it refuses a frame, so a test can check that the hardware and the model
refuse for the same reason.

Tree::

    CrossbarError
    ├── FabricParameterError (ValueError)   parameters the hardware cannot be built with
    ├── RouteError (ValueError)             a routing the fabric cannot carry
    ├── DataWidthError (ValueError)         a beat's data wider than the fabric's data width
    ├── BitstreamError (ValueError)         a partial bitstream the wrapper refuses (``code``)
    │   ├── CrcError                            1: the CRC-8 does not match
    │   ├── LengthError                         2: the wrong number of bits
    │   ├── MagicError                          3: no magic nibble 0xA
    │   ├── SlotMismatchError                   4: packed for another slot
    │   ├── SelectorRangeError                  5: a source the slot does not have
    │   └── RefusedRouteError                   6: one source twice, or a loop on itself
    ├── BitstreamImageError (ValueError)    a HEX image that holds no crossbar bitstream
    ├── BusError (ValueError)               a plug, unplug or swap the Morphing Bus cannot carry
    │   └── UnknownBoardError                   an identification word no known board sends
    ├── SynthesisError (RuntimeError)       yosys is missing or refused the design
    ├── ModelBuildError (RuntimeError)      Verilator could not build the fabric's model library
    ├── FabricStallError (RuntimeError)     the RTL model delivered nothing within its cycle bound
    └── ModelUnusableError (RuntimeError)   a call to an RTL model closed, or stalled before
"""

from __future__ import annotations


class CrossbarError(Exception):
    """Base class of every error this package raises."""


class FabricParameterError(CrossbarError, ValueError):
    """Fabric parameters the hardware cannot be built with (N, widths, cluster size, kinds)."""


class RouteError(CrossbarError, ValueError):
    """A routing the fabric cannot carry: unreachable source, two consumers, or a cycle."""


class DataWidthError(CrossbarError, ValueError):
    """A beat whose data does not fit the fabric's data width."""


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


class BusError(CrossbarError, ValueError):
    """A plug, unplug or swap the Morphing Bus cannot carry out (a free or taken port, a board
    moved out of reach of its modules, modules another board uses), or a catalogue of boards
    it cannot serve."""


class UnknownBoardError(BusError):
    """An identification word that no board of the bus's catalogue sends."""


class SynthesisError(CrossbarError, RuntimeError):
    """Yosys is missing or refused the design."""


class ModelBuildError(CrossbarError, RuntimeError):
    """Verilator or the C++ compiler could not build the fabric's model library."""


class FabricStallError(CrossbarError, RuntimeError):
    """The RTL model did not deliver the beats or the verdict expected within its cycle bound
    (a model that disagrees with the routing the Python side checked)."""


class ModelUnusableError(CrossbarError, RuntimeError):
    """A call to an RTL model that was closed, or that stalled earlier (its design may still
    hold beats of the call that gave up, so no later result could be trusted)."""
