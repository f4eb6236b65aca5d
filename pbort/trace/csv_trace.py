"""A trace as CSV: one row per port per sample, `time,pbo,port,value`.

Long rows suit pandas (`pd.read_csv(...).pivot_table(index="time", columns=["pbo", "port"])`)
and spreadsheets alike. A vector or frame port's value is one JSON array in its cell. Rows reach
the file at least every `FLUSH_SECONDS` of host time and when the trace closes, so a process
killed outright leaves whole rows up to its last flush.
"""

from __future__ import annotations

import contextlib
import csv
import json
import time
from collections.abc import Sequence
from pathlib import Path

from pbort.errors import TraceWriteError
from pbort.ports import PortSpec
from pbort.trace.recorder import Sample

FLUSH_SECONDS = 0.5
HEADER = ("time", "pbo", "port", "value")


class CsvTrace:
    """Writes samples to a CSV file until `close`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file = path.open("w", newline="", encoding="utf-8")
        self._rows = csv.writer(self._file)
        self._rows.writerow(HEADER)
        self._flushed = time.monotonic()

    def wants(self, pbo: str) -> bool:
        """Every sample."""
        return True

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """One row per port of the sample; TraceWriteError when the disk refuses them (the
        file is closed then)."""
        try:
            for name, value in sample.values.items():
                cell = json.dumps(value) if isinstance(value, list) else repr(value)
                self._rows.writerow((repr(sample.time), sample.pbo, name, cell))
            if time.monotonic() - self._flushed >= FLUSH_SECONDS:
                self._file.flush()
                self._flushed = time.monotonic()
        except OSError as error:
            with contextlib.suppress(OSError):
                self._file.close()  # its last rows cannot reach the disk either
            raise TraceWriteError(self.path, error) from None

    def close(self) -> None:
        """Flush and close the file (TraceWriteError when the disk refuses the last rows);
        calling it again does nothing."""
        if not self._file.closed:
            try:
                self._file.close()
            except OSError as error:
                raise TraceWriteError(self.path, error) from None
