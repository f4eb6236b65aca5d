"""The firmware's loader and receiver built for the host (firmware/host, under ASan and UBSan),
driven as a node: lines and binary frames in, answers out (cut by hexmigrate's own Deframer, so
binary answers come whole), and the harness's directives (restart, clock, power cut, flash
dump). A sanitizer finding ends the process with its report on stderr, which every
check here raises with."""

from __future__ import annotations

import os
import select
import subprocess
import time
from pathlib import Path

from hexmigrate.links.framing import Deframer, cobs_encode
from hexmigrate.transfer.layout import line_sum

ANSWER_TIMEOUT = 10.0
"""Seconds the harness may take to answer (a long line of a sanitized build)."""
STX = b"\x02"


class HostNode:
    """The harness at `path`, started with --directives; a context manager that ends it."""

    def __init__(self, path: Path) -> None:
        env = {**os.environ, "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=1"}
        self.process = subprocess.Popen(
            [str(path), "--directives"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
        )
        self._deframer = Deframer(max_line=4096)  # an answer line may be longer than a request
        self._pending: list[bytes] = []
        self.read_until(b"refresh-node host ready")

    def send(self, data: bytes) -> None:
        """Bytes to the node, as they are."""
        assert self.process.stdin is not None
        try:
            self.process.stdin.write(data)
            self.process.stdin.flush()
        except BrokenPipeError:
            raise AssertionError(f"the harness died: {self.errors()}") from None

    def command(self, text: str) -> None:
        """A command line with its checksum."""
        self.send(b"%s *%02X\n" % (text.encode(), line_sum(text)))

    def read_until(self, start: bytes) -> list[bytes]:
        """The messages (lines, binary messages) that come up to and including the first line
        that starts with `start`."""
        lines: list[bytes] = []
        deadline = time.monotonic() + ANSWER_TIMEOUT
        assert self.process.stdout is not None
        out = self.process.stdout.fileno()
        while True:
            while self._pending:
                line = self._pending.pop(0)
                lines.append(line)
                if line.startswith(start):
                    return lines
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([out], [], [], left)[0]:
                raise AssertionError(f"no line starting {start!r} in {ANSWER_TIMEOUT} s: {lines}")
            chunk = os.read(out, 65536)
            if not chunk:
                raise AssertionError(f"the harness ended: {self.errors()}")
            self._pending += self._deframer.feed(chunk)

    def answers(self, data: bytes) -> list[bytes]:
        """What the node answers to `data` (whole lines), up to a PING's PONG (left out). An
        STX in `data` is sent as ETX: at a line's start it would be the harness's directive,
        and to the node both are the same, a control byte no message starts with."""
        self.send(data.replace(STX, b"\x03"))
        self.command("PING")
        return self.read_until(b"PONG")[:-1]

    def binary(self, messages: list[bytes], raw: bytes = b"") -> list[bytes]:
        """What the node answers to binary `messages`, each framed as 0x00 COBS 0x00 (whatever
        its first byte), then `raw` as it is: the messages up to a PING's PONG (left out).
        Frames go untouched: the harness knows a frame from a directive."""
        framed = (b"\x00" + cobs_encode(message) + b"\x00" for message in messages)
        self.send(b"".join(framed) + raw)
        self.command("PING")
        return self.read_until(b"PONG")[:-1]

    def directive(self, text: str) -> list[bytes]:
        """A harness directive (R restart, T clock, C N power cut, P cut pending?, S PATH flash
        dump, L PATH flash load): the lines up to its ``#ok``."""
        self.send(STX + text.encode() + b"\n")
        return self.read_until(b"#ok")

    def errors(self) -> str:
        """What the harness wrote on stderr once it ended (a sanitizer's report)."""
        self.process.kill()
        assert self.process.stderr is not None
        return self.process.stderr.read().decode(errors="replace")[-3000:]

    def close(self) -> str:
        """End the harness (its stdin closed: it returns from main); its stderr."""
        assert self.process.stdin is not None
        self.process.stdin.close()
        try:
            self.process.wait(ANSWER_TIMEOUT)
        finally:
            self.process.kill()
        assert self.process.stderr is not None
        return self.process.stderr.read().decode(errors="replace")

    def __enter__(self) -> HostNode:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.process.kill()
        self.process.wait()
