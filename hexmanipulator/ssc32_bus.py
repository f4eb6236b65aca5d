"""The servo bus over an SSC-32 on a serial port (any pyserial URL, a device or a pty path).

A move is one group command, ``#<ch>P<pw>...T<ms>``, so the six servos start and stop together.
A read is ``QP<ch>...``: one byte per channel, the pulse / 10 (a 1.1 degree step on an S3003).
The SSC-32 has no wire back from the servos: what it reports is the pulse it outputs, which the
servos follow at their own speed, and no current at all. The bus therefore estimates each servo's
current from the S3003's data sheet: running current while its pulse changes, idle otherwise.
"""

from __future__ import annotations

import math
import termios
import time

import numpy as np
import serial  # type: ignore[import-untyped]

from hexmanipulator.errors import CableCutError, ServoSilentError
from hexmanipulator.geometry import Geometry
from hexmanipulator.servo_bus import Reading, crank_angles, servo_angles
from servo_emulators.datasheet import S3003

_PORT_ERRORS = (OSError, serial.SerialException, termios.error)
"""What a port whose far end vanished raises: pyserial's error, the OS's, or termios' (a tty
flush on a hung-up pty)."""
REPLY_TIMEOUT = 0.1
"""How long the bus waits for an answer: the guide promises one within 5 ms."""


class Ssc32Bus:
    """An SSC-32 at `url` (8N1 at `bit_rate` baud), driving the legs on the geometry's channels."""

    def __init__(self, url: str, geometry: Geometry, bit_rate: int = 115200) -> None:
        self.url = url
        self.geometry = geometry
        self._channels = geometry.channels
        self._volts = geometry.supply_volts
        self._last_pulses: np.ndarray | None = None
        try:
            self._port = serial.serial_for_url(url, baudrate=bit_rate, timeout=REPLY_TIMEOUT)
        except (OSError, ValueError) as error:
            raise CableCutError(f"{url}: cannot open the SSC-32's port: {error}") from error

    def move(self, angles: np.ndarray, duration: float) -> None:
        pulses = [S3003.pulse_of_angle(a) for a in servo_angles(self.geometry, angles)]
        group = "".join(f"#{ch}P{round(p)}" for ch, p in zip(self._channels, pulses, strict=True))
        self._send(f"{group}T{math.ceil(duration * 1000)}\r")

    def read(self) -> Reading:
        query = "".join(f"QP{ch}" for ch in self._channels)
        self._send(query + "\r")
        answer = self._receive(len(self._channels), "QP")
        pulses = 10.0 * np.frombuffer(answer, dtype=np.uint8)
        if np.any(pulses == 0):
            off = [ch for ch, p in zip(self._channels, pulses, strict=True) if p == 0]
            raise ServoSilentError(f"{self.url}: SSC-32 sends no pulse on channel(s) {off}")
        servos = np.array([S3003.angle_of_pulse(p) for p in pulses])
        return Reading(crank_angles(self.geometry, servos), self._currents(pulses), self._volts, ())

    def close(self) -> None:
        self._port.close()

    def _currents(self, pulses: np.ndarray) -> np.ndarray:
        """The S3003's data-sheet current for each servo: running while its pulse moved."""
        last = self._last_pulses
        moved = np.ones(len(pulses), bool) if last is None else pulses != last
        self._last_pulses = pulses
        running, idle = S3003.running_ma(self._volts), S3003.idle_ma(self._volts)
        return np.where(moved, running, idle)

    def _send(self, text: str) -> None:
        try:
            self._port.reset_input_buffer()
            self._port.write(text.encode("ascii"))
            self._port.flush()
        except _PORT_ERRORS as error:
            raise CableCutError(f"{self.url}: serial cable cut ({error})") from error

    def _receive(self, count: int, what: str) -> bytes:
        data = b""
        deadline = time.monotonic() + REPLY_TIMEOUT
        try:
            while len(data) < count and time.monotonic() < deadline:
                data += self._port.read(count - len(data))
        except _PORT_ERRORS as error:
            raise CableCutError(f"{self.url}: serial cable cut ({error})") from error
        if len(data) < count:
            raise ServoSilentError(
                f"{self.url}: SSC-32 stopped answering: {len(data)} of {count} bytes to {what} "
                f"within {REPLY_TIMEOUT:g} s"
            )
        return data
