"""The thread both emulator servers run: one step at a time until stopped, or until the link fails.

A step waits at most `poll` seconds for input (a port read, a CAN receive), so `stop` returns
within about one poll. A step that raises one of the link's `failures` ends the thread: the error
is kept in `error` and logged, unless it came because the server was stopping (closing a port
under a read fails it, and that is no fault).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

logger = logging.getLogger(__name__)
JOIN_SLACK = 1.0
"""Seconds `stop` waits beyond one poll for the thread: a step that blocks longer is a bug."""


class ServingThread:
    """Runs `step` in a daemon thread named `name` until `stop` or a failure."""

    def __init__(
        self,
        name: str,
        step: Callable[[], None],
        failures: type[Exception] | tuple[type[Exception], ...],
        poll: float,
    ) -> None:
        self.name = name
        self.error: Exception | None = None
        """The failure that ended the thread, if one did."""
        self._step = step
        self._failures = failures
        self._poll = poll
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def stop(self) -> bool:
        """Stop the thread and wait for it; False when it was already stopped."""
        if self._stopping.is_set():
            return False
        self._stopping.set()
        self._thread.join(timeout=self._poll + JOIN_SLACK)
        return True

    def _run(self) -> None:
        while not self._stopping.is_set():
            try:
                self._step()
            except self._failures as error:
                if not self._stopping.is_set():
                    self.error = error
                    logger.warning("%s stops: %s", self.name, error)
                return
