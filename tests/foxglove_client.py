"""A Foxglove WebSocket client for the tests, on `websockets`: what a Foxglove app does with a
live view (read the advertised channels, subscribe by topic, decode each message), with every
wait bounded by a deadline."""

from __future__ import annotations

import json
import struct
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from websockets.sync.client import ClientConnection, connect

from pbort.trace.live import SUBPROTOCOL

MESSAGE_DATA = 0x01
"""The opcode of a binary frame carrying a subscribed message."""


@contextmanager
def live_client(url: str, timeout: float = 10.0) -> Iterator[FoxgloveClient]:
    """A client of the live view at `url`, connected for the block."""
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=timeout, close_timeout=1) as ws:
        yield FoxgloveClient(ws, timeout)


class FoxgloveClient:
    """A client on connection `ws`, each wait at most `timeout` seconds."""

    def __init__(self, ws: ClientConnection, timeout: float) -> None:
        self.timeout = timeout
        self._ws = ws
        self.info = json.loads(ws.recv(timeout=timeout))
        self.channels: dict[str, dict[str, Any]] = {}
        """Every channel advertised so far, by topic."""
        self._subscriptions: dict[int, str] = {}

    def advertised(self, *topics: str) -> dict[str, dict[str, Any]]:
        """The channels of `topics`, once each is advertised (AssertionError at the deadline)."""
        deadline = time.monotonic() + self.timeout
        while not set(topics) <= self.channels.keys():
            self._take(self._next(deadline))
        return {topic: self.channels[topic] for topic in topics}

    def subscribe(self, *topics: str) -> None:
        """Subscribe to `topics` (advertised first)."""
        channels = self.advertised(*topics)
        subscriptions = []
        for topic in topics:
            number = len(self._subscriptions) + 1
            self._subscriptions[number] = topic
            subscriptions.append({"id": number, "channelId": channels[topic]["id"]})
        self._ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def messages(self, count: int) -> list[tuple[str, int, dict[str, Any]]]:
        """The next `count` messages of the subscriptions: (topic, log time in ns, message)."""
        got = self._collect(count, time.monotonic() + self.timeout)
        assert len(got) == count, f"{len(got)} of {count} messages within {self.timeout} s"
        return got

    def poll(self, seconds: float) -> list[tuple[str, int, dict[str, Any]]]:
        """The messages that arrive within `seconds` (none at all is no failure)."""
        return self._collect(None, time.monotonic() + seconds)

    def _collect(self, count: int | None, deadline: float) -> list[tuple[str, int, dict[str, Any]]]:
        got: list[tuple[str, int, dict[str, Any]]] = []
        while count is None or len(got) < count:
            try:
                frame = self._ws.recv(timeout=max(0.0, deadline - time.monotonic()))
            except TimeoutError:
                break
            if isinstance(frame, bytes) and frame[:1] == bytes([MESSAGE_DATA]):
                _, subscription, stamp = struct.unpack_from("<BIQ", frame)
                got.append((self._subscriptions[subscription], stamp, json.loads(frame[13:])))
            else:
                self._take(frame)
        return got

    def _next(self, deadline: float) -> str | bytes:
        left = deadline - time.monotonic()
        assert left > 0, f"nothing more from the live view within {self.timeout} s"
        try:
            return self._ws.recv(timeout=left)
        except TimeoutError:
            raise AssertionError(
                f"nothing more from the live view within {self.timeout} s"
            ) from None

    def _take(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            operation = json.loads(frame)
            if operation.get("op") == "advertise":
                self.channels |= {channel["topic"]: channel for channel in operation["channels"]}
