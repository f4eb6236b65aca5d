"""The live view: a kernel's samples (and a manager's events and reports) served as they come
over the Foxglove WebSocket protocol, by the pinned `foxglove-sdk`, on the channels an MCAP
trace holds (`pbort.trace.json_channels`), so that a Foxglove layout saved for a recording
works live.

The SDK's server runs on threads of its own: logging a message never waits for a client, a
client that stops reading loses its oldest messages (the SDK's backlog), and a message is
serialised only while a client subscribes to its channel (a node that nobody watches pays
nothing but the samples' first channel declarations).
"""

from __future__ import annotations

from typing import Any

from pbort.errors import LiveViewError
from pbort.trace.json_channels import JsonChannels

SUBPROTOCOL = "foxglove.sdk.v1"
"""The WebSocket subprotocol the server speaks (Foxglove's app connects with it)."""


class LiveView(JsonChannels):
    """A Foxglove WebSocket server on `host`:`port` (0: any free port), named `name`, serving
    the channels declared on it until `close`."""

    def __init__(self, host: str, port: int, name: str) -> None:
        super().__init__()
        import foxglove  # the live extra, imported when a live view is asked for

        self._foxglove = foxglove
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(
                name=name, host=host, port=port, context=self._context
            )
        except RuntimeError as error:  # the SDK's FoxgloveError
            raise LiveViewError(
                f"--foxglove {host}:{port}: expected an address this host can listen on, got "
                f"{str(error).removeprefix('FoxgloveError: ')}"
            ) from None
        self.host = host
        self.port = self._server.port
        """The port the server listens on (the one chosen, for port 0)."""
        self._channels: dict[str, Any] = {}
        self._closed = False

    @property
    def url(self) -> str:
        """Where Foxglove connects: ``ws://HOST:PORT`` (an IPv6 host in brackets)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def _declare(self, topic: str, title: str, schema: bytes) -> None:
        foxglove = self._foxglove
        self._channels[topic] = foxglove.Channel(
            topic,
            schema=foxglove.Schema(name=title, encoding="jsonschema", data=schema),
            message_encoding="json",
            context=self._context,
        )

    def _log(self, topic: str, stamp: int, data: bytes) -> None:
        self._channels[topic].log(data, log_time=stamp)

    def _read(self, topic: str) -> bool:
        channel = self._channels.get(topic)
        return channel is not None and channel.has_sinks()

    def close(self) -> None:
        """Stop the server (its clients are disconnected); calling it again does nothing."""
        if not self._closed:
            self._closed = True
            self._server.stop()
