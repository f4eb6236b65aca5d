"""An SSC-32 emulator serving a byte port in a thread, with the faults a real one shows.

    with Ssc32Server(Ssc32(), PtyPort()) as server:
        print(server.port.path)        # open it with a terminal at any baud rate, type VER<Enter>

Faults for tests and demos: `mute()` makes the controller stop answering (a brown-out that left
it hung: bytes go in, nothing comes out); `cut()` pulls the cable (the port closes, the host's
next read or write fails).
"""

from __future__ import annotations

import logging
import threading

from firmware_sim.servos.ports import POLL_INTERVAL, BytePort
from firmware_sim.servos.ssc32 import Ssc32

logger = logging.getLogger(__name__)


class Ssc32Server:
    """Reads the port, feeds the controller, writes its replies, until closed."""

    def __init__(self, controller: Ssc32, port: BytePort) -> None:
        self.controller = controller
        self.port = port
        self.muted = False
        self.received = 0
        """Bytes taken from the host and fed to the controller so far."""
        self.error: OSError | None = None
        """Why the port failed, if it did."""
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._serve, name=f"ssc32 {port.name}", daemon=True)
        self._thread.start()

    def mute(self) -> None:
        """The controller stops answering; it still reads (and ignores) what arrives."""
        self.muted = True

    def cut(self) -> None:
        """Pull the cable: stop serving and close the port."""
        self.close()

    def close(self) -> None:
        """Stop the thread and close the port; later calls do nothing."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._thread.join(timeout=10 * POLL_INTERVAL + 1.0)
        self.port.close()

    def __enter__(self) -> Ssc32Server:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _serve(self) -> None:
        while not self._stopping.is_set():
            try:
                data = self.port.read()
                if not data:
                    continue
                reply = self.controller.feed(data)
                self.received += len(data)
                if reply and not self.muted:
                    self.port.write(reply)
            except OSError as error:
                if not self._stopping.is_set():
                    self.error = error
                    logger.warning("SSC-32 emulator stops: %s", error)
                return
