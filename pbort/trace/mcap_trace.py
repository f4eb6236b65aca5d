"""A trace as MCAP (https://mcap.dev), which Foxglove and PlotJuggler open: one channel per
PBO (topic ``/PBO``), JSON messages, a JSON schema per channel, log times in the kernel's
nanoseconds.

`McapTrace.message` is the general entry: the visual-servoing report writes its samples and
events through it too. Chunks are compressed as they fill; the summary that lets a reader seek
is written when the trace closes. A process killed outright leaves the chunks written so far and
no summary: `mcap recover` (the mcap CLI) rebuilds a whole file from them.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mcap.writer import Writer

from pbort.ports import PortKind, PortSpec
from pbort.trace.recorder import Sample

LIBRARY = "refresh-toolchain"
CHUNK_SIZE = 64 * 1024
"""Bytes of messages per compressed chunk: small enough that a stopped node loses little."""


class McapTrace:
    """Writes messages to an MCAP file until `close`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._stream = path.open("wb")
        self._writer = Writer(self._stream, chunk_size=CHUNK_SIZE)
        self._writer.start(profile="", library=LIBRARY)
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self._closed = False

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """One message on the PBO's channel: the time and every port."""
        if sample.pbo not in self._channels:
            properties = {port.name: _port_schema(port) for port in ports}
            self.channel(f"/{sample.pbo}", f"PBO {sample.pbo}", properties)
        self.message(f"/{sample.pbo}", sample.time, sample.values)

    def channel(self, topic: str, title: str, properties: Mapping[str, Any]) -> None:
        """Declare a channel whose messages are objects of `properties` (JSON schema), plus the
        time in seconds."""
        schema = {
            "title": title,
            "type": "object",
            "properties": {"time": {"type": "number", "description": "seconds"}, **properties},
        }
        schema_id = self._writer.register_schema(
            name=title, encoding="jsonschema", data=json.dumps(schema).encode()
        )
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schema_id
        )

    def message(self, topic: str, time: float, values: Mapping[str, Any]) -> None:
        """One message on a declared channel, logged at `time` (seconds, not negative)."""
        stamp = round(max(time, 0.0) * 1e9)
        data = json.dumps({"time": time, **values}).encode()
        self._writer.add_message(
            self._channels[topic],
            log_time=stamp,
            data=data,
            publish_time=stamp,
            sequence=self._sequence,
        )
        self._sequence += 1

    def close(self) -> None:
        """Write the summary and close the file; calling it again does nothing."""
        if not self._closed:
            self._closed = True
            self._writer.finish()
            self._stream.close()


def _port_schema(port: PortSpec) -> dict[str, Any]:
    """A port's value in JSON schema: a number, or nested arrays of numbers."""
    number = {"type": "integer" if port.dtype[1:2] in ("i", "u") else "number"}
    schema: dict[str, Any] = number
    for _ in port.shape if port.kind is not PortKind.SCALAR else ():
        schema = {"type": "array", "items": schema}
    return {**schema, "description": f"{port.direction.value} {port.kind.value} {port.dtype}"}
