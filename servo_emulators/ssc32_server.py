"""An SSC-32 emulator serving a byte port in a thread, with the faults a real one shows.

    with Ssc32Server(Ssc32(), PtyPort()) as server:
        print(server.port.path)        # open it with a terminal at any baud rate, type VER<Enter>

Faults for tests and demos: `mute()` makes the controller stop answering (a brown-out that left
it hung: bytes go in, nothing comes out); `cut()` pulls the cable (the port closes, the host's
next read or write fails).
"""

from __future__ import annotations

from servo_emulators.byte_ports import POLL_INTERVAL, BytePort
from servo_emulators.serving import ServingThread
from servo_emulators.ssc32 import Ssc32


class Ssc32Server:
    """Reads the port, feeds the controller, writes its replies, until closed."""

    def __init__(self, controller: Ssc32, port: BytePort) -> None:
        self.controller = controller
        self.port = port
        self.muted = False
        self.received = 0
        """Bytes taken from the host and fed to the controller so far."""
        self._thread = ServingThread(
            f"SSC-32 emulator on {port.name}", self._step, OSError, POLL_INTERVAL
        )

    @property
    def error(self) -> Exception | None:
        """Why the port failed, if it did."""
        return self._thread.error

    def mute(self) -> None:
        """The controller stops answering; it still reads (and ignores) what arrives."""
        self.muted = True

    def cut(self) -> None:
        """Pull the cable: stop serving and close the port."""
        self.close()

    def close(self) -> None:
        """Stop the thread and close the port; later calls do nothing."""
        if self._thread.stop():
            self.port.close()

    def __enter__(self) -> Ssc32Server:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _step(self) -> None:
        data = self.port.read()
        if not data:
            return
        reply = self.controller.feed(data)
        self.received += len(data)
        if reply and not self.muted:
            self.port.write(reply)
