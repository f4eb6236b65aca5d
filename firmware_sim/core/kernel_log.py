"""The kernel's and the modules' log lines, taken from the ``pbort`` logger.

pbort logs through Python's logging: its own warnings (a fault, a missed start) and each module's
LOG service calls, as ``NAME: text`` at INFO. `run` keeps all of them in the node's log with
virtual time (`into_node_log`). (A PBO also keeps its module's recent lines itself:
`pbort.module_log`, which refusals quote and a listening node prints and answers.)
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from firmware_sim.core.node import Node
from pbort.code import Method

LOGGER = "pbort"
KERNEL_LOGGER = "pbort.kernel"
"""pbort's own warnings (a fault, a missed start), apart from the modules' lines."""


class _Forward(logging.Handler):
    """Hands each record's message (of `level` and above, and that `wanted` takes) to a
    function."""

    def __init__(
        self,
        take: Callable[[str], None],
        level: int = logging.INFO,
        wanted: Callable[[logging.LogRecord], bool] = lambda record: True,
    ) -> None:
        super().__init__(level)
        self._take = take
        self._wanted = wanted

    def emit(self, record: logging.LogRecord) -> None:
        if self._wanted(record):
            self._take(record.getMessage())


@contextmanager
def _attached(take: Callable[[str], None], echo: bool = True) -> Iterator[None]:
    """Forward pbort's INFO records to `take` while inside; `echo` False keeps them off the
    handlers above (standard error)."""
    logger = logging.getLogger(LOGGER)
    handler = _Forward(take)
    level, propagate = logger.level, logger.propagate
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = propagate and echo
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        logger.propagate = propagate


@contextmanager
def into_node_log(node: Node, echo: bool) -> Iterator[None]:
    """Put the kernel's and the modules' log lines into `node.log`, with virtual time, instead
    of on standard error (where they still go when `echo`)."""
    with _attached(lambda text: node.log.append((node.kernel.now, text)), echo):
        yield


@contextmanager
def kernel_warnings_said(say: Callable[[str], None]) -> Iterator[None]:
    """Say each of the kernel's own warnings while inside: a PBO that faults into ERROR, with
    why (``PBO 'Gauge': cycle faulted: ...``), as it happens. An operator at a listening node's
    terminal sees the fault there, not only in ``hexmigrate ps --verbose``; a PBO faults once
    until it is cleared, so these lines cannot flood. A failed method a caller asked for
    (init, on, off, kill, clear: a START, a STOP) is left out: its caller reports it, with
    what the module logged."""
    logger = logging.getLogger(KERNEL_LOGGER)
    handler = _Forward(say, logging.WARNING, _unasked)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)


def _unasked(record: logging.LogRecord) -> bool:
    """Whether a kernel warning is of a failure nobody asked for: a job's method (cycle,
    evaluate, estimate), the error handler, or no method at all."""
    return getattr(record, "method", None) not in _ASKED


_ASKED = {Method.INIT, Method.ON, Method.OFF, Method.KILL, Method.CLEAR}
"""The methods a caller runs (registering, a START, a STOP, a CLEAR), which report a failure to
that caller."""
