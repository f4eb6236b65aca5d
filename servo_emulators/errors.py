"""The exception tree of the servo emulators.

Every refusal of a servo emulator (the S3003 model, the SSC-32, the CAN servo nodes, their ports)
raises a subclass of `ServoEmulatorError`, so ``python -m servo_emulators`` catches one class.
Each class also inherits the builtin it refines.

Tree::

    ServoEmulatorError                a servo emulator refuses its set-up or a command
    ├── ServoSpecError (ValueError)       a supply or an angle outside the S3003's data sheet
    ├── ServoSetupError (ValueError)      emulator parameters out of range: channels, nodes,
    │                                     a clock that runs backwards
    ├── Ssc32CommandError (ValueError)    a line the SSC-32 would not execute (ignored, with
    │                                     its reason kept)
    └── ServoPortError (OSError)          a serial port or CAN bus the emulator cannot open,
                                          or one that failed under it
"""

from __future__ import annotations


class ServoEmulatorError(Exception):
    """Base class of every error the servo emulators raise."""


class ServoSpecError(ServoEmulatorError, ValueError):
    """A supply voltage or a shaft angle the S3003's data sheet does not allow."""


class ServoSetupError(ServoEmulatorError, ValueError):
    """Emulator parameters out of range: a channel or node count, a node number, a step back in
    time."""


class Ssc32CommandError(ServoEmulatorError, ValueError):
    """A line the SSC-32 would not execute; the emulator ignores it and keeps the reason."""


class ServoPortError(ServoEmulatorError, OSError):
    """A serial port or CAN bus an emulator cannot open, or that failed under it; the message
    names it and says why."""
