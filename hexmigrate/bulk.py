"""The vectorised fast path of `hexmigrate.records.decode`.

A 1 MiB image is 65,536 lines; checking them one by one in Python costs well over a microsecond
each. Here the whole text is converted by a single `bytes.fromhex` and every per-record check
(start code, byte count, checksum, ascending order) is one numpy operation over all records.

This path only has to *prove* a file well formed. It returns None at the first doubt, and the
caller then runs the line-by-line decoder, which finds and reports the exact first error. So
the two paths agree by construction on what is accepted, and errors are always the precise ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

START_CODE = ord(":")
DATA, EOF, EXTENDED_SEGMENT, EXTENDED_LINEAR = 0x00, 0x01, 0x02, 0x04


@dataclass(frozen=True)
class BulkParse:
    """A well-formed file: its data as ascending contiguous pieces, and the other records.

    `others` holds ``(line_number, raw_record)`` for every record that is neither data nor the
    final EOF, in file order, for the caller to check and apply one by one.
    """

    pieces: list[tuple[int, bytes]]
    others: list[tuple[int, bytes]]


def parse_well_formed(lines: list[str]) -> BulkParse | None:
    """Parse `lines` (no line endings, no trailing blank lines) if they are provably a
    well-formed file whose data records ascend without overlap; otherwise return None."""
    blob, starts, sizes = _records(lines)
    if blob is None:
        return None
    types = blob[starts + 3]
    other = np.flatnonzero(types != DATA)
    if not other.size or other[-1] != len(lines) - 1 or types[-1] != EOF:
        return None
    others = [(int(i) + 1, blob[starts[i] : starts[i] + sizes[i]].tobytes()) for i in other[:-1]]
    bases = _bases(others)
    if bases is None:
        return None
    data = np.flatnonzero((types == DATA) & (sizes > 5))
    preceding = np.searchsorted(other, data)
    addresses = (
        bases[preceding]
        + (blob[starts[data] + 1].astype(np.int64) << 8)
        + blob[starts[data] + 2].astype(np.int64)
    )
    counts = sizes[data] - 5
    return _pieces(blob, starts[data] + 4, addresses, counts, others)


def _records(lines: list[str]) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
    """The bytes of all records, where each record starts and its size; None when any line
    is not ':' followed by pairs of hex digits, or a byte count or checksum is wrong."""
    empty = np.empty(0, np.int64)
    joined = "".join(lines)
    if not lines or joined.count(":") != len(lines) or not joined.isascii():
        return None, empty, empty
    try:
        blob = np.frombuffer(bytes.fromhex(joined.replace(":", "")), np.uint8)
    except ValueError:
        return None, empty, empty
    digits = np.fromiter(map(len, lines), np.int64, len(lines)) - 1
    # fromhex skips whitespace: equal totals prove every character but ':' is a digit.
    if (digits & 1).any() or (digits < 10).any() or int(digits.sum()) != 2 * blob.size:
        return None, empty, empty
    line_starts = np.concatenate(([0], np.cumsum(digits + 1)[:-1]))
    if (np.frombuffer(joined.encode("ascii"), np.uint8)[line_starts] != START_CODE).any():
        return None, empty, empty
    sizes = digits // 2
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    if (blob[starts].astype(np.int64) + 5 != sizes).any():
        return None, empty, empty
    if (np.add.reduceat(blob, starts, dtype=np.uint32) & 0xFF).any():
        return None, empty, empty
    return blob, starts, sizes


def _bases(others: list[tuple[int, bytes]]) -> np.ndarray | None:
    """The address base in force after each non-data record, with 0 before the first."""
    bases = [0]
    for _, raw in others:
        base = bases[-1]
        if raw[3] in (EXTENDED_SEGMENT, EXTENDED_LINEAR):
            if raw[0] != 2:
                return None
            base = int.from_bytes(raw[4:6], "big") << (4 if raw[3] == EXTENDED_SEGMENT else 16)
        elif raw[3] == EOF:
            return None
        bases.append(base)
    return np.array(bases, np.int64)


def _pieces(
    blob: np.ndarray,
    payload_starts: np.ndarray,
    addresses: np.ndarray,
    counts: np.ndarray,
    others: list[tuple[int, bytes]],
) -> BulkParse | None:
    """Gather the payloads into contiguous pieces, or None if data does not ascend."""
    if not counts.size:
        return BulkParse([], others)
    ends = addresses + counts
    if (addresses[1:] < ends[:-1]).any() or int(ends[-1]) > 1 << 32:
        return None
    offsets = np.concatenate(([0], np.cumsum(counts)[:-1]))
    gather = np.repeat(payload_starts - offsets, counts) + np.arange(int(counts.sum()))
    payload = blob[gather].tobytes()
    breaks = np.flatnonzero(addresses[1:] != ends[:-1]) + 1
    bounds = [0, *breaks.tolist(), len(counts)]
    pieces = []
    for first, last in pairwise(bounds):
        start = int(offsets[first])
        size = int(ends[last - 1] - addresses[first])
        pieces.append((int(addresses[first]), payload[start : start + size]))
    return BulkParse(pieces, others)
