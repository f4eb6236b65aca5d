"""The exception tree of firmware_sim.

Every failure of an emulated node (its flash, loader, guest CPU, kernel services, the values its
command sets, its reconfiguration port) raises a subclass of `FirmwareSimError`, so the node's
commands catch one class. Each class also inherits the builtin it refines, so code that catches
``RuntimeError`` or ``ValueError`` (the transfer protocol's receiver does) still sees them.

Tree::

    FirmwareSimError                    the root: every error firmware_sim raises
    ├── FlashError (RuntimeError)       a flash operation the hardware refuses, a flash file that
    │                                   does not fit the flash
    ├── FlashFullError (RuntimeError)   no run of free flash blocks is long enough
    ├── DirectoryError (ValueError)     a module directory that cannot hold or describe the modules
    ├── LoadError (RuntimeError)        the loader cannot install an image (misplaced pointer,
    │                                   read-back mismatch)
    ├── BootError (RuntimeError)        a directory entry that is not a whole module in flash
    ├── RegistrationError (RuntimeError) a loaded module's init subroutine did not register it
    ├── TrustError (PermissionError)    a node with trusted keys refuses a module: not signed, an
    │                                   unknown key, a broken signature, a downgrade
    ├── OutOfSramError (MemoryError)    no free SRAM block is large enough
    ├── CpuClosedError (RuntimeError)   the CPU was used after it was closed
    ├── NativeLibraryError (ImportError) the CPU's compiled block counter is not installed
    ├── KernelAccessError (ValueError)  a kernel read or write outside the memory map (a bug)
    ├── ServiceFault (ValueError)       a kernel service refuses a guest's arguments: the guest
    │                                   call ends with a fault, the module goes to ERROR
    ├── PortValueError (ValueError)     a value (``--set PBO.port=VALUE``) the port's declared
    │                                   type cannot hold exactly
    ├── StartError (RuntimeError)       a PBO that did not start, with what its module logged
    ├── PboFailedError (RuntimeError)   a run that ended with a PBO in ERROR
    ├── PowerReportError (ValueError)   a module reported a power draw the budget cannot take
    ├── ReconfigurationPortError (LookupError)
    │                                   no FPGA reconfiguration port is installed, or the one
    │                                   installed cannot build the fabric asked for
    ├── BridgeError (RuntimeError)      a port between nodes that cannot be set up, or a lock-step
    │                                   step that cannot run (a bridge's value did not come)
    ├── QemuError (RuntimeError)        QEMU or the C firmware could not be built, started or
    │                                   reached (``firmware-sim qemu``)
    └── GdbServerError (OSError)        the GDB server cannot listen where it is asked to

Two exceptions of firmware_sim stand outside the tree on purpose, because they are control flow
and not failures a caller should report:

- `firmware_sim.core.flash.PowerCut` is a ``BaseException`` (like ``KeyboardInterrupt``): it
  emulates the power failing mid-erase or mid-program, so no ``except Exception`` on the way out
  may undo anything; after it nothing runs, as on a node without power.
- `firmware_sim.core.guest._Refused` carries the negative status the REGISTER service returns to a
  guest; it never leaves the registrar.
"""

from __future__ import annotations


class FirmwareSimError(Exception):
    """Base class of every error firmware_sim raises."""


class FlashError(FirmwareSimError, RuntimeError):
    """A flash operation the hardware would refuse (bad address, program without erase), or a
    backing file that does not fit the flash."""


class FlashFullError(FirmwareSimError, RuntimeError):
    """No run of free flash blocks is long enough (or the blocks asked for are taken)."""


class DirectoryError(FirmwareSimError, ValueError):
    """A module directory record that cannot be written (too many modules, a name too long) or
    read (a slot that is neither erased nor valid)."""


class LoadError(FirmwareSimError, RuntimeError):
    """The node cannot install the module (no room, read-back mismatch, misplaced pointer)."""


class BootError(FirmwareSimError, RuntimeError):
    """A directory entry that does not describe a whole module in flash (checked at boot)."""


class RegistrationError(FirmwareSimError, RuntimeError):
    """A loaded module did not register: its init subroutine faulted or its descriptor is bad."""


class TrustError(FirmwareSimError, PermissionError):
    """A node that trusts keys refuses a module before its init runs; the message is the reason
    the sender is told ("not signed", "signed by an unknown key", "signature does not match",
    "version 1.1.0 is older than the installed 1.2.0")."""


class OutOfSramError(FirmwareSimError, MemoryError):
    """No free block of SRAM is large enough for an allocation."""


class CpuClosedError(FirmwareSimError, RuntimeError):
    """The CPU was closed; its memory and code are gone."""


class NativeLibraryError(FirmwareSimError, ImportError):
    """The CPU's compiled block counter (firmware_sim/core/block_counter.c) is missing: the
    package was not built or installed whole."""


class KernelAccessError(FirmwareSimError, ValueError):
    """A kernel read or write outside the memory map (a kernel bug, not a guest fault)."""


class ServiceFault(FirmwareSimError, ValueError):
    """Raised by a kernel service to end the running guest call with a fault; the text says what
    was wrong with the guest's arguments."""


class PortValueError(FirmwareSimError, ValueError):
    """A value for a port that the port's declared type cannot hold exactly (a fraction for an
    integer port, a number out of its range, infinity or NaN)."""


class StartError(FirmwareSimError, RuntimeError):
    """A PBO did not start (registration, constants, init or on failed); the text carries the
    kernel's reason and the lines the module logged while it tried."""


class PboFailedError(FirmwareSimError, RuntimeError):
    """A run ended with a PBO in ERROR (a fault, the watchdog, a method that failed): the run
    printed its report, and the command exits non-zero."""


class PowerReportError(FirmwareSimError, ValueError):
    """A module's evaluator reported a power draw the node's budget cannot take (negative or not
    a finite number)."""


class ReconfigurationPortError(FirmwareSimError, LookupError):
    """``--fpga``: no FPGA reconfiguration port is installed (or more than one), or the one
    installed cannot build a fabric of the size asked for."""


class BridgeError(FirmwareSimError, RuntimeError):
    """A port between nodes that cannot be set up (a busy bridge number, a port too large for a
    link, an unknown wire), or a lock-step Advance whose imported values did not come."""


class QemuError(FirmwareSimError, RuntimeError):
    """QEMU or the firmware could not be started, built or reached: the message says which and
    what to do."""


class GdbServerError(FirmwareSimError, OSError):
    """The GDB server cannot listen where it is asked to (``--gdb HOST:PORT``): the message
    names the address, as the system's own error does not."""
