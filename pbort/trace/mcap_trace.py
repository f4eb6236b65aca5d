"""A trace as MCAP (https://mcap.dev), which Foxglove and PlotJuggler open: the channels of
`pbort.trace.json_channels` (one per PBO, topic ``/PBO``, JSON messages, a JSON schema per
channel, log times in the kernel's nanoseconds), the same the live view serves.

`McapTrace.message` is the general entry: an application's report writes its samples and
events through it too. Chunks are compressed as they fill; the summary that lets a reader seek
is written when the trace closes. A process killed outright leaves the chunks written so far and
no summary: `mcap recover` (the mcap CLI) rebuilds a whole file from them.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from mcap.writer import Writer

from pbort.errors import TraceWriteError
from pbort.trace.json_channels import JsonChannels

LIBRARY = "refresh-toolchain"
CHUNK_SIZE = 64 * 1024
"""Bytes of messages per compressed chunk: small enough that a stopped node loses little."""


class McapTrace(JsonChannels):
    """Writes messages to an MCAP file until `close`."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path
        self._stream = path.open("wb")
        self._writer = Writer(self._stream, chunk_size=CHUNK_SIZE)
        self._writer.start(profile="", library=LIBRARY)
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self._closed = False

    def _declare(self, topic: str, title: str, schema: bytes) -> None:
        schema_id = self._writer.register_schema(name=title, encoding="jsonschema", data=schema)
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schema_id
        )

    def _log(self, topic: str, stamp: int, data: bytes) -> None:
        """One message; TraceWriteError when the disk refuses a chunk (the file is closed then,
        without its summary: `mcap recover` reads the chunks before)."""
        try:
            self._writer.add_message(
                self._channels[topic],
                log_time=stamp,
                data=data,
                publish_time=stamp,
                sequence=self._sequence,
            )
        except OSError as error:
            self._closed = True
            with contextlib.suppress(OSError):
                self._stream.close()
            raise TraceWriteError(self.path, error) from None
        self._sequence += 1

    def close(self) -> None:
        """Write the summary and close the file (TraceWriteError when the disk refuses them);
        calling it again does nothing."""
        if not self._closed:
            self._closed = True
            try:
                self._writer.finish()
                self._stream.close()
            except OSError as error:
                with contextlib.suppress(OSError):
                    self._stream.close()
                raise TraceWriteError(self.path, error) from None
