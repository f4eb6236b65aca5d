"""The Lynxmotion SSC-32 servo controller's ASCII protocol, interpreted over 32 emulated servos.

What the SSC-32U user guide documents, and this emulator does (docs/servos.md cites the pages):

=============================  ================================================================
``#<ch>P<pw>S<spd>...T<ms>``   move channels 0-31 to pulse widths (500-2500 us, clipped), each at
                               most `spd` us/s, the whole group in at least `ms` milliseconds;
                               a group with S or T starts and ends every channel together
``#<ch>PO<us>...``             position offset of -100..100 us added to a channel's pulses,
                               from now on (QP reports the pulse with its offset)
``#<ch>H`` / ``#<ch>L``        discrete output high or low (the channel stops sending pulses)
``#<bank>:<value>``            byte output to bank 0-3 (8 channels each)
``Q``                          movement status: ``.`` when the last move is complete, ``+`` while
                               it runs
``QP<ch>QP<ch>...``            one byte per channel: the pulse width it outputs, / 10
``STOP<ch>``                   stop a channel's ramp where it is now
``A``..``F``, ``AL``..``FL``   digital inputs: ``1`` per input (weak pull-ups, nothing wired)
``VER``                        the firmware version, ``SSC32-V2.50USB`` and CR
=============================  ================================================================

Every command ends with CR (13). Spaces, tabs and line feeds are ignored, and so is letter case;
ESC (27) cancels the line typed so far. Commands of different types may not be mixed in one
group. The SSC-32 sends nothing back for a line it cannot execute (the guide defines no error
reply), so this emulator discards such a line silently, counting it in `ignored` and keeping the
reason in `last_ignored` for whoever debugs the host. A channel that never had a pulse jumps to
its first position at once: the controller cannot know where the servo was.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable
from dataclasses import replace

from servo_emulators.bank import Ramp, ServoBank
from servo_emulators.datasheet import (
    SSC32_CHANNELS,
    SSC32_OFFSET_LIMIT_US,
    SSC32_PULSE_MAX_US,
    SSC32_PULSE_MIN_US,
)
from servo_emulators.errors import ServoSetupError, Ssc32CommandError

VERSION = b"SSC32-V2.50USB\r"
TIME_MAX_MS = 65535
MAX_LINE = 256
"""Longer lines are dropped as garbage, up to their CR: no real command group is that long."""
CR, ESC = 0x0D, 0x1B
_SKIPPED = b" \t\n"
_DROP_SKIPPED = str.maketrans("", "", _SKIPPED.decode("ascii"))

_SERVO = re.compile(r"#(\d+)P(\d+)(?:S(\d+))?")
_OFFSET = re.compile(r"#(\d+)PO(-?\d+)")
_LEVEL = re.compile(r"#(\d+)([HL])")
_BYTE = re.compile(r"#(\d+):(\d+)")
_TIME = re.compile(r"T(\d+)$")
_QUERY_PULSE = re.compile(r"(?:QP(\d+))+")
_INPUTS = re.compile(r"(?:[A-F]L?)+")


class Ssc32:
    """The controller: feed it the bytes a host sends, get the bytes it answers.

    `now` is the controller's clock in seconds (virtual time in tests, `time.monotonic` for a
    live emulator); every call first steps the servos to it. `feed` and `execute` hold one lock,
    so a server thread and a test may both talk to the controller.
    """

    def __init__(self, bank: ServoBank | None = None, now: Callable[[], float] | None = None):
        self.bank = bank if bank is not None else ServoBank(SSC32_CHANNELS)
        if len(self.bank) != SSC32_CHANNELS:
            raise ServoSetupError(
                f"expected a bank of {SSC32_CHANNELS} channels, got {len(self.bank)}"
            )
        self.now = now if now is not None else _monotonic_since(time.monotonic())
        self.offsets = [0] * SSC32_CHANNELS
        self.levels: list[bool | None] = [None] * SSC32_CHANNELS
        """Each channel's discrete output level, or None while it is a servo channel."""
        self.move_end = 0.0
        """When the last group move ends (its full time, even if channels were stopped)."""
        self.ignored = 0
        self.last_ignored = ""
        self._line = bytearray()
        self._lock = threading.Lock()
        self._overlong = False
        """True from a line's MAX_LINE + 1st character to its CR: the rest is dropped too, so a
        tail that happens to read as a command is not executed."""

    def feed(self, data: bytes) -> bytes:
        """Take bytes from the host; return every reply the complete lines among them produce."""
        with self._lock:
            return self._feed(data)

    def execute(self, line: str) -> bytes:
        """Run one command line (without its CR); the reply, or b"" (also for a bad line)."""
        with self._lock:
            return self._execute(line)

    def _feed(self, data: bytes) -> bytes:
        replies = bytearray()
        for byte in data:
            if byte == CR:
                line, self._line = self._line.decode("ascii", "replace"), bytearray()
                if not self._overlong:
                    replies += self._execute(line)
                self._overlong = False
            elif byte == ESC:
                self._line.clear()
                self._overlong = False
            elif byte not in _SKIPPED and not self._overlong:
                self._line.append(byte)
                if len(self._line) > MAX_LINE:
                    self._ignore(f"line longer than {MAX_LINE} characters")
                    self._line.clear()
                    self._overlong = True
        return bytes(replies)

    def _execute(self, line: str) -> bytes:
        self.bank.advance_to(self.now())
        text = line.upper().translate(_DROP_SKIPPED)
        if not text:
            return b""
        try:
            return self._dispatch(text)
        except Ssc32CommandError as error:
            self._ignore(f"{line!r}: {error}")
            return b""

    def _ignore(self, reason: str) -> None:
        self.ignored += 1
        self.last_ignored = reason

    def _dispatch(self, text: str) -> bytes:
        if text.startswith("#"):
            self._group(text)
            return b""
        if text == "Q":
            return b"+" if self.bank.time < self.move_end else b"."
        if text == "VER":
            return VERSION
        if _QUERY_PULSE.fullmatch(text):
            return bytes(self._pulse_byte(_channel(c)) for c in re.findall(r"QP(\d+)", text))
        if text.startswith("STOP"):
            self._stop(_channel(text[4:]))
            return b""
        if _INPUTS.fullmatch(text):
            return b"1" * len(re.findall(r"[A-F]L?", text))
        raise Ssc32CommandError("expected a documented SSC-32 command")

    def _group(self, text: str) -> None:
        """A command group: all of one type, executed after the CR."""
        body, move_time = _split_time(text)
        moves = _items(_SERVO, body)
        if moves is not None:
            self._move(moves, move_time)
            return
        if move_time is not None:
            raise Ssc32CommandError("expected T only at the end of a servo move group")
        for pattern, handler in (
            (_OFFSET, self._offsets),
            (_LEVEL, self._levels),
            (_BYTE, self._bytes),
        ):
            items = _items(pattern, text)
            if items is not None:
                handler(items)
                return
        raise Ssc32CommandError("expected a group of one command type (P, PO, H/L or :)")

    def _move(self, items: list[tuple[str, ...]], move_time_ms: int | None) -> None:
        """Ramp every channel of the group over the one duration the guide's rules give."""
        now = self.bank.time
        targets: dict[int, tuple[float, float]] = {}
        duration = (move_time_ms or 0) / 1000
        for channel, pulse, speed in items:
            ch = _channel(channel)
            end = float(
                min(SSC32_PULSE_MAX_US, max(SSC32_PULSE_MIN_US, int(pulse))) + self.offsets[ch]
            )
            current = self.bank.pulse(ch)
            start = end if current is None else current
            targets[ch] = (start, end)
            if speed and int(speed) > 0:
                duration = max(duration, abs(end - start) / int(speed))
        for ch, (start, end) in targets.items():
            self.levels[ch] = None
            self.bank.set_ramp(ch, Ramp(start, end, now, duration))
        self.move_end = now + duration

    def _offsets(self, items: list[tuple[str, ...]]) -> None:
        for channel, value in items:
            offset = int(value)
            if abs(offset) > SSC32_OFFSET_LIMIT_US:
                raise Ssc32CommandError(
                    f"expected an offset of -{SSC32_OFFSET_LIMIT_US}..{SSC32_OFFSET_LIMIT_US} us, "
                    f"got {offset}"
                )
            ch = _channel(channel)
            shift, self.offsets[ch] = offset - self.offsets[ch], offset
            ramp = self.bank.ramps[ch]
            if ramp is not None:
                shifted = replace(ramp, start=ramp.start + shift, end=ramp.end + shift)
                self.bank.set_ramp(ch, shifted)

    def _levels(self, items: list[tuple[str, ...]]) -> None:
        for channel, level in items:
            self._set_level(_channel(channel), level == "H")

    def _bytes(self, items: list[tuple[str, ...]]) -> None:
        for bank, value in items:
            number, byte = int(bank), int(value)
            if number > 3 or byte > 255:
                raise Ssc32CommandError(f"expected bank 0-3 and value 0-255, got {number}:{byte}")
            for bit in range(8):
                self._set_level(8 * number + bit, bool(byte >> bit & 1))

    def _set_level(self, channel: int, high: bool) -> None:
        self.levels[channel] = high
        self.bank.set_ramp(channel, None)

    def _stop(self, channel: int) -> None:
        pulse = self.bank.pulse(channel)
        if pulse is not None:
            self.bank.set_ramp(channel, Ramp(pulse, pulse))

    def _pulse_byte(self, channel: int) -> int:
        pulse = self.bank.pulse(channel)
        return 0 if pulse is None else min(255, round(pulse / 10))


def _channel(text: str) -> int:
    if not text.isdigit() or int(text) >= SSC32_CHANNELS:
        raise Ssc32CommandError(f"expected a channel 0-{SSC32_CHANNELS - 1}, got {text!r}")
    return int(text)


def _split_time(text: str) -> tuple[str, int | None]:
    """A move group without its trailing T<ms>, and the time."""
    match = _TIME.search(text)
    if match is None:
        return text, None
    milliseconds = int(match.group(1))
    if milliseconds > TIME_MAX_MS:
        raise Ssc32CommandError(f"expected T of at most {TIME_MAX_MS} ms, got {milliseconds}")
    return text[: match.start()], milliseconds


def _items(pattern: re.Pattern[str], text: str) -> list[tuple[str, ...]] | None:
    """The commands of a group if the whole text is a run of `pattern`, else None."""
    items, position = [], 0
    while position < len(text):
        match = pattern.match(text, position)
        if match is None:
            return None
        items.append(match.groups(default=""))
        position = match.end()
    return items


def _monotonic_since(start: float) -> Callable[[], float]:
    """A clock in seconds since `start` on the host's monotonic clock."""
    return lambda: time.monotonic() - start
