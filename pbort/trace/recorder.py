"""The recorder: after each job, every port of that PBO with the kernel's time."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pbort.errors import TraceWriteError
from pbort.kernel import Kernel
from pbort.ports import PortSpec

Value = float | int | list
"""A port's value as a trace holds it: a number, or nested lists for a vector or a frame."""


@dataclass(frozen=True)
class Sample:
    """One PBO's ports right after one of its jobs, at `time` (the kernel's seconds)."""

    time: float
    pbo: str
    values: dict[str, Value]


class TraceWriter(Protocol):
    """Where samples go: a file format, a plot, a live view."""

    def wants(self, pbo: str) -> bool:
        """Whether a sample of `pbo` would go anywhere now (a live view nobody watches takes
        none: the samples are not even read)."""

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """Write one sample of a PBO whose ports are `ports`."""


class Recorder:
    """Samples every job of `kernel` into `writers` until `stop` (or the kernel closes).

    A trace file the disk refuses (TraceWriteError) ends the kernel's run, unless `on_failure`
    takes it: then that trace stops and the others record on (a listening node serves on)."""

    def __init__(
        self,
        kernel: Kernel,
        writers: Sequence[TraceWriter],
        on_failure: Callable[[TraceWriteError], None] | None = None,
    ) -> None:
        self.kernel = kernel
        self.writers = tuple(writers)
        self._on_failure = on_failure
        self._observer: Callable[[str, float], None] = self._record
        kernel.observe(self._observer)

    def stop(self) -> None:
        """Stop sampling (the writers stay open: their owner closes them)."""
        self.kernel.unobserve(self._observer)

    def _record(self, pbo: str, time: float) -> None:
        writers = [writer for writer in self.writers if writer.wants(pbo)]
        if not writers:
            return
        ports = self.kernel.ports(pbo)
        values = {port.name: plain(self.kernel.value(f"{pbo}.{port.name}")) for port in ports}
        sample = Sample(time, pbo, values)
        for writer in writers:
            try:
                writer.write(sample, ports)
            except TraceWriteError as error:
                if self._on_failure is None:
                    raise
                self.writers = tuple(kept for kept in self.writers if kept is not writer)
                self._on_failure(error)


def plain(value: object) -> Value:
    """A port value as plain Python numbers (JSON and CSV take them as they are)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    assert isinstance(value, (int, float, list))
    return value
