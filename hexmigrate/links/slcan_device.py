"""The device side of an SLCAN (Lawicel ASCII) adapter on a pty, bridged to a python-can bus.

A real SLCAN adapter is a serial port that speaks CAN in ASCII lines ended by CR. This module
plays the adapter for an emulated node: the node listens on an in-process python-can bus (a
`virtual` channel), and another process opens the pty's far end with python-can's `slcan`
interface (``can://slcan//dev/pts/5``) as it would a USB adapter::

    with SlcanDevice("node0") as device:            # the node's process
        node = open_link("can://virtual/node0?role=node")
        print(device.url)                           # can://slcan//dev/pts/5 for the host

Commands understood (each ends with CR; the reply is CR for OK, BEL for refused):

    Sn         bit rate n = 0..9 (10k, 20k, 50k, 100k, 125k, 250k, 500k, 800k (python-can: 750k),
               1M, 83.3k); only while closed
    sXXYY      bit timing registers; only while closed
    O / L / C  open the channel, open it listen-only, close it
    tIIILDD..  send a standard frame (3 hex id digits, length 0..8, data) -> reply z CR
    TIIIIIIIILDD..  send an extended frame (8 hex id digits) -> reply Z CR
    rIIIL / RIIIIIIIIL  send a remote frame -> z CR / Z CR
    F          status flags as two hex digits (bit 3: data overrun), cleared by reading
    V / N      hardware and software version (V1013) / serial number (NRFSH)
    Z0         timestamps off (the only setting supported)

Frames from the bus go to the pty in the same t/T/r/R form while the channel is open. As an
adapter receives only what is on the wire while it is open, a frame stamped while the channel was
closed (python-can stamps with time.time(); since the device started) is dropped even when a busy
process hands it on after the channel opened; a stamp of another clock (a bus that preserves its
senders' stamps) is not judged. The bridge adds no bit-rate timing: it moves frames as fast as
both processes do. Refused: FD frames and rates (d, D, b, B, Y), acceptance filters (M, m) and
timestamps (Z1), which python-can's driver does not use.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from collections.abc import Callable

import can

from hexmigrate.links.serial import write_within
from hexmigrate.links.stream import POLL_INTERVAL

BITRATE_CODES = frozenset("0123456789")
DLC_DIGITS = frozenset("012345678")
OK = b"\r"
BELL = b"\a"
VERSION = b"V1013\r"
SERIAL_NUMBER = b"NRFSH\r"
OVERRUN_FLAG = 0x08
MAX_COMMAND = 64
"""Longer than any command this device knows (an extended frame with 8 bytes is 27 chars)."""
WRITE_TIMEOUT = 1.0
"""How long a frame for the host waits for room in the pty before it is dropped as an overrun."""


class SlcanDevice:
    """An SLCAN adapter on a new pty, bridged to `channel` of python-can's `interface`."""

    def __init__(self, channel: str, interface: str = "virtual") -> None:
        self.bus = can.Bus(interface=interface, channel=channel, ignore_config=True)
        master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(master, False)
        self._master = master
        self.path = os.ttyname(self._slave)
        self.to_bus = 0
        """Frames the host sent onto the bus."""
        self.to_host = 0
        """Frames from the bus written to the host."""
        self.refused = 0
        """Commands answered with BEL."""
        self.overruns = 0
        """Frames for the host dropped because it did not read the pty."""
        self._mode = "closed"
        self._started_at = time.time()
        self._opened_at = self._started_at
        """When the channel last opened (time.time(), the clock of python-can's timestamps)."""
        self._flags = 0
        self._stalled = False
        self._write_lock = threading.Lock()
        self._stopping = threading.Event()
        self._commands: dict[str, Callable[[str], bytes]] = {
            "S": self._set_bitrate,
            "s": self._set_bitrate,
            "O": lambda _: self._switch("open"),
            "L": lambda _: self._switch("listen"),
            "C": lambda _: self._switch("closed"),
            "t": self._transmit,
            "T": self._transmit,
            "r": self._transmit,
            "R": self._transmit,
            "F": self._status,
            "V": lambda _: VERSION,
            "N": lambda _: SERIAL_NUMBER,
            "Z": lambda command: OK if command == "Z0" else BELL,
        }
        self._notifier = can.Notifier(self.bus, [self._to_host], timeout=POLL_INTERVAL)
        self._reader = threading.Thread(
            target=self._read_loop, name=f"slcan {self.path}", daemon=True
        )
        self._reader.start()

    @property
    def url(self) -> str:
        """The link URL another process opens to reach this device."""
        return f"can://slcan/{self.path}"

    def close(self) -> None:
        """Stop the bridge and close the pty and the bus; later calls do nothing."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._reader.join(timeout=10 * POLL_INTERVAL + 1.0)
        self._notifier.stop(timeout=10 * POLL_INTERVAL + 1.0)
        self.bus.shutdown()
        os.close(self._master)
        os.close(self._slave)

    def __enter__(self) -> SlcanDevice:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def handle(self, command: str) -> bytes:
        """The reply to one command (without its CR): what the adapter's firmware does."""
        handler = self._commands.get(command[:1])
        reply = handler(command) if handler is not None else BELL
        if reply == BELL:
            self.refused += 1
        return reply

    def _read_loop(self) -> None:
        pending = b""
        while not self._stopping.is_set():
            readable, _, _ = select.select([self._master], [], [], POLL_INTERVAL)
            if not readable:
                continue
            try:
                pending += os.read(self._master, 4096)
            except BlockingIOError:
                continue
            *commands, pending = pending.replace(b"\n", b"").split(b"\r")
            for command in commands:
                if command:
                    self._write(self.handle(command.decode("ascii", "replace")))
            if len(pending) > MAX_COMMAND:
                pending = b""
                self.refused += 1
                self._write(BELL)

    def _set_bitrate(self, command: str) -> bytes:
        valid = command[1:] in BITRATE_CODES if command[0] == "S" else _is_hex(command[1:], 4)
        return OK if self._mode == "closed" and valid else BELL

    def _switch(self, mode: str) -> bytes:
        if mode != "closed" and self._mode != "closed":
            return BELL
        self._opened_at = time.time()
        self._mode = mode
        return OK

    def _transmit(self, command: str) -> bytes:
        if self._mode != "open":
            return BELL
        try:
            frame = parse_frame(command)
        except ValueError:
            return BELL
        self.bus.send(frame)
        self.to_bus += 1
        return b"Z\r" if frame.is_extended_id else b"z\r"

    def _status(self, command: str) -> bytes:
        if command != "F" or self._mode == "closed":
            return BELL
        flags, self._flags = self._flags, 0
        return f"F{flags:02X}\r".encode()

    def _to_host(self, frame: can.Message) -> None:
        """Notifier callback: a frame from the bus, written to the host while open."""
        if self._mode == "closed" or frame.is_error_frame or frame.is_fd:
            return
        if self._started_at <= frame.timestamp < self._opened_at:
            return  # on the wire while the channel was closed
        if self._write(format_frame(frame).encode() + b"\r"):
            self.to_host += 1
        else:
            self.overruns += 1
            self._flags |= OVERRUN_FLAG

    def _write(self, data: bytes) -> bool:
        """Write `data` whole to the host; False if the pty stayed full. After one overrun the
        next frames do not wait, so a host that went away costs no time per frame."""
        with self._write_lock:
            timeout = 0 if self._stalled else WRITE_TIMEOUT
            self._stalled = not write_within(self._master, data, timeout)
            return not self._stalled


def parse_frame(command: str) -> can.Message:
    """The frame a t, T, r or R command sends; ValueError if it is malformed."""
    kind = command[0]
    extended = kind in "TR"
    id_end = 9 if extended else 4
    identifier = command[1:id_end]
    length = command[id_end : id_end + 1]
    data = command[id_end + 1 :]
    if not _is_hex(identifier, id_end - 1) or length not in DLC_DIGITS:
        raise ValueError(f"expected {kind}, an id and a length, got {command!r}")
    arbitration_id = int(identifier, 16)
    if arbitration_id > (0x1FFFFFFF if extended else 0x7FF):
        raise ValueError(f"expected an id that fits the frame, got {identifier}")
    if kind in "rR":
        if data:
            raise ValueError(f"expected no data in a remote frame, got {data!r}")
        payload = b""
    elif not _is_hex(data, 2 * int(length)):
        raise ValueError(f"expected {length} data bytes in hex, got {data!r}")
    else:
        payload = bytes.fromhex(data)
    return can.Message(
        arbitration_id=arbitration_id,
        is_extended_id=extended,
        is_remote_frame=kind in "rR",
        dlc=int(length),
        data=payload,
    )


def format_frame(frame: can.Message) -> str:
    """The t/T/r/R line (without CR) that carries `frame` to the host."""
    kind = "r" if frame.is_remote_frame else "t"
    if frame.is_extended_id:
        kind = kind.upper()
        identifier = f"{frame.arbitration_id:08X}"
    else:
        identifier = f"{frame.arbitration_id:03X}"
    data = "" if frame.is_remote_frame else frame.data.hex().upper()
    return f"{kind}{identifier}{frame.dlc}{data}"


def _is_hex(text: str, length: int) -> bool:
    return len(text) == length and all(c in "0123456789abcdefABCDEF" for c in text)
