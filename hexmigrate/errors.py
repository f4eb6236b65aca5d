"""The exception tree of hexmigrate: one root, `HexmigrateError`, so that a command catches one
class and reports the rest uniformly. Each class also inherits the builtin exception it refines
(python-can style), so code that knows nothing of hexmigrate still catches it as a `ValueError`,
an `OSError` or a `TimeoutError`.

Every failure to read a HEX file or to build a module image raises a subclass of `HexError`. Each
carries where the problem is (`path`, `line`) and a message that says what was expected and what
came instead; `str(error)` renders them as ``FILE:LINE: message``, the form compilers use, so
editors can jump to the place. The other classes say what failed in their message (the link's
URL, the request that went unanswered, the field of a message).

Tree::

    HexmigrateError                    the root: every error hexmigrate raises
    ├── HexError (ValueError)          a HEX file or module image that cannot be used
    │   ├── HexSyntaxError                 one line cannot be decoded as a record
    │   │   ├── BadStartCodeError
    │   │   ├── OddLengthError
    │   │   ├── NonHexDigitError
    │   │   ├── ByteCountError
    │   │   └── ChecksumError
    │   ├── HexRecordError                 the record decodes but its content is not allowed
    │   │   ├── UnknownRecordTypeError
    │   │   ├── RecordSizeError
    │   │   ├── AddressFieldError
    │   │   └── DuplicateStartAddressError
    │   ├── HexStructureError              the records do not form a valid file
    │   │   ├── MissingEofError
    │   │   ├── RecordAfterEofError
    │   │   ├── TextAfterEofError
    │   │   ├── AddressOverflowError
    │   │   ├── OverlapError
    │   │   ├── OrderError
    │   │   └── SignatureRecordError       09 records out of order or too many
    │   └── ModuleError                    the file is not a valid relocatable module
    │       ├── MultipleInitError
    │       ├── MissingInitError
    │       ├── GapError
    │       ├── DuplicateRelocationError
    │       ├── RelocationOutsideImageError
    │       ├── InitOutsideImageError
    │       ├── ModuleSourceError          an ELF, map or binary the image is built from is unusable
    │       └── ModuleCheckError           a module a node would refuse or run wrongly
    │           ├── PointerAlignmentError      a 07 word unaligned or across a flash block
    │           ├── PointerTargetError         a 07 word that holds no address in the image
    │           ├── InitAlignmentError         an init off a 4-byte instruction boundary
    │           ├── CompressedCodeError        RVC code for a node that runs RV32IM
    │           ├── MissingRelocationsError    an ELF linked without --emit-relocs
    │           ├── ImmovableRelocationError   a relocation no 07 record fixes (medlow code,
    │           │                              a global offset table, thread-local storage)
    │           ├── MapMismatchError           a map file from another build than the binary
    │           ├── NameLengthError            a descriptor name longer than 15 characters
    │           └── DescriptorCountError       no single valid descriptor: two, or a broken one
    ├── DescriptorError (ValueError)   bytes that are not a PBO module descriptor
    │   └── AbiMismatchError               a wrong magic or ABI version
    ├── MessageError (ValueError)      bytes that are not a transfer protocol message, or a
    │                                  message that cannot be written in the mode asked for
    ├── LinkError (OSError)            a link cannot be opened or has failed
    │   └── LinkUrlError (ValueError)      a malformed link URL
    ├── SigningError (ValueError)      a key, version or signature area that cannot be used
    │   ├── KeyFileError                   a file that is not a supported PEM key
    │   ├── VersionError                   a version that is not MAJOR.MINOR.REVISION
    │   ├── TlvError                       a signature area whose TLVs cannot be read
    │   └── SignatureError                 the signature does not hold (`reason` says why)
    ├── LockStepError (ValueError)     a lock-step time master set up wrong (its quantum, a route)
    └── TransferError (RuntimeError)   the node refused, or a transfer could not go on
        ├── NoAnswer (TimeoutError)        a request went unanswered through every try
        ├── NodeRefused                    the node said no, fatally (`reason`: its words)
        ├── TransferForgotten (LookupError)   the transfer to resume is gone: send anew
        └── TransferInterrupted (ConnectionError)   the link failed mid-transfer: resume it
"""

from __future__ import annotations

from pathlib import Path


class HexmigrateError(Exception):
    """Base class of every error hexmigrate raises: a command catches this one class."""


class HexError(HexmigrateError, ValueError):
    """Base class of every hexmigrate format error; carries the file and line it concerns."""

    def __init__(self, message: str, *, line: int | None = None, path: str | Path | None = None):
        super().__init__(message)
        self.message = message
        self.line = line
        self.path = str(path) if path is not None else None

    def with_path(self, path: str | Path) -> HexError:
        """Attach the file name once the caller knows it (the codec works on text, not files)."""
        self.path = str(path)
        return self

    @property
    def location(self) -> str:
        """``FILE:LINE``, ``FILE``, ``line N`` or an empty string, whatever is known."""
        if self.path is not None and self.line is not None:
            return f"{self.path}:{self.line}"
        if self.path is not None:
            return self.path
        if self.line is not None:
            return f"line {self.line}"
        return ""

    def __str__(self) -> str:
        return f"{self.location}: {self.message}" if self.location else self.message


class HexSyntaxError(HexError):
    """A line cannot be decoded as an Intel HEX record."""


class BadStartCodeError(HexSyntaxError):
    """A line does not start with ':'."""


class OddLengthError(HexSyntaxError):
    """A line has an odd number of hex digits, so the last byte is cut in half."""


class NonHexDigitError(HexSyntaxError):
    """A line holds a character that is not a hexadecimal digit."""


class ByteCountError(HexSyntaxError):
    """The byte count field does not match the number of bytes on the line."""


class ChecksumError(HexSyntaxError):
    """The checksum byte is not the two's complement of the sum of the other bytes."""


class HexRecordError(HexError):
    """A record decodes but is not allowed in a module file."""


class UnknownRecordTypeError(HexRecordError):
    """The record type is none of 00-05, 07, 08."""


class RecordSizeError(HexRecordError):
    """A record type with a fixed payload size (01-05, 07, 08) has another byte count."""


class AddressFieldError(HexRecordError):
    """A record other than data has an address field other than 0000."""


class DuplicateStartAddressError(HexRecordError):
    """A second start address record (03 or 05) appears."""


class HexStructureError(HexError):
    """The records are valid one by one but do not form a valid file."""


class MissingEofError(HexStructureError):
    """The file has no end-of-file record."""


class RecordAfterEofError(HexStructureError):
    """A record follows the end-of-file record, which must be last."""


class TextAfterEofError(HexStructureError):
    """Something other than blank lines follows the end-of-file record."""


class AddressOverflowError(HexStructureError):
    """Data would extend past the 4 GiB address space."""


class OverlapError(HexStructureError):
    """Two data records write the same address."""


class OrderError(HexStructureError):
    """Data records do not come in ascending address order, as a streaming node needs them."""


class SignatureRecordError(HexStructureError):
    """Signature records (09) whose offsets do not follow one another from 0, or too many."""


class ModuleError(HexError):
    """The file or its sources do not describe a valid relocatable module."""


class MultipleInitError(ModuleError):
    """More than one module initialization pointer (record 08)."""


class MissingInitError(ModuleError):
    """A module file has no module initialization pointer (record 08)."""


class GapError(ModuleError):
    """A module file's data is not one contiguous run (a module fills consecutive flash blocks)."""


class DuplicateRelocationError(ModuleError):
    """The same pointer word is listed twice by offset function pointer records (07)."""


class RelocationOutsideImageError(ModuleError):
    """An offset function pointer (07) names a word that is not entirely inside the image data."""


class InitOutsideImageError(ModuleError):
    """The module initialization pointer (08) targets an address outside the image data."""


class ModuleSourceError(ModuleError):
    """An ELF file, a map file or a raw binary cannot give a module image."""


# The module checks (hexmigrate.checks): what `pack` and `verify` refuse before a node would.


class ModuleCheckError(ModuleError):
    """A module that decodes but that a node would refuse, or load and then run wrongly."""


class PointerAlignmentError(ModuleCheckError):
    """An 07 pointer word that is not 4-byte aligned, or that straddles a 256-byte flash block
    (the node fixes pointer words block by block)."""


class PointerTargetError(ModuleCheckError):
    """An 07 record names a word whose value is no address inside the image: not a pointer
    the node should move."""


class InitAlignmentError(ModuleCheckError):
    """The init subroutine (08) is not on an instruction boundary, or not in code."""


class CompressedCodeError(ModuleCheckError):
    """Compressed (RVC) code, which a node's RV32IM core cannot run."""


class MissingRelocationsError(ModuleCheckError):
    """An absolute address no relocation lists: an ELF linked without ``--emit-relocs``, or a
    descriptor method pointer without its 07 record."""


class ImmovableRelocationError(ModuleCheckError):
    """A relocation that pins the module to its link base: no 07 record fixes it (instructions
    that hold parts of absolute addresses, as ``-mcmodel=medlow`` writes, a GOT entry,
    thread-local storage, an absolute value that is not a pointer word)."""


class MapMismatchError(ModuleCheckError):
    """A map file that does not describe the raw binary it comes with."""


class NameLengthError(ModuleCheckError):
    """A descriptor name longer than the ABI's 15 characters (16 bytes with its NUL)."""


class DescriptorCountError(ModuleCheckError):
    """An image with more than one PBO descriptor, or with one that starts as a descriptor but
    does not decode (a name that is no identifier): a node registers one, a signature names the
    first a scan finds."""


class DescriptorError(HexmigrateError, ValueError):
    """The bytes are not a valid descriptor of a supported ABI version."""


class AbiMismatchError(DescriptorError):
    """The bytes are not a descriptor of this ABI: a wrong magic or ABI version.

    Kept apart from other descriptor errors because the kernel answers it with its own status
    (PBO_ERR_ABI) rather than PBO_ERR_INVALID.
    """


class MessageError(HexmigrateError, ValueError):
    """Bytes that are not a valid protocol message, or a message that cannot be encoded in the
    mode asked for (a binary-only message in hex mode, a value too large for its field)."""


class LinkError(HexmigrateError, OSError):
    """A link cannot be opened or has failed (closed, cut, device gone)."""


class LinkUrlError(LinkError, ValueError):
    """A link URL is malformed; the message shows the expected form."""


class SigningError(HexmigrateError, ValueError):
    """A key, a version or a signature area that cannot be used (hexmigrate.signing)."""


class KeyFileError(SigningError):
    """A file that is not an Ed25519 or ECDSA P-256 key in PEM, as `imgtool keygen` writes."""


class VersionError(SigningError):
    """A module version that is not MAJOR.MINOR.REVISION within MCUboot's field sizes."""


class TlvError(SigningError):
    """A signature area whose TLVs cannot be read: a wrong magic, a length past the end, a
    missing or repeated entry."""


class SignatureError(SigningError):
    """The signature of a module does not hold; `reason` is the short cause a node reports:
    "not signed", "signed by an unknown key" or "signature does not match"."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


class LockStepError(HexmigrateError, ValueError):
    """A lock-step `TimeMaster` set up wrong: a quantum under a microsecond, no node, a bridge
    routed twice or to a node it does not grant time to."""


class TransferError(HexmigrateError, RuntimeError):
    """The node refused, or stopped answering: the transfer did not happen."""


class NoAnswer(TransferError, TimeoutError):
    """A request went unanswered through every try; the message says how many tries, how long
    each waited and what was heard."""


class NodeRefused(TransferError):
    """The node refused a request fatally; `reason` is its refusal, word for word, for a caller
    that acts on one refusal in particular (a RESUME of a transfer the node no longer holds)."""

    def __init__(self, reason: str) -> None:
        super().__init__(f"the node refused: {reason}")
        self.reason = reason


class TransferForgotten(TransferError, LookupError):
    """A transfer to resume that the node no longer holds (it restarted, or dropped the transfer
    when idle): only a new transfer from the start installs the module."""


class TransferInterrupted(TransferError, ConnectionError):
    """The link failed mid-transfer; `Sender.resume(image, tid)` on a new link continues it."""

    def __init__(self, message: str, tid: int, programmed: int) -> None:
        super().__init__(message)
        self.tid = tid
        self.programmed = programmed
