"""Channels of JSON messages, each with a JSON schema: what an MCAP trace holds and what the
Foxglove live view serves, declared once for both, so that a layout made for a recording
works live (same topics, same schemas, same messages).

A PBO's channel is topic ``/PBO`` with schema ``PBO PBO``: the time in seconds and every port
(a number, or nested arrays of numbers for a vector or frame). `channel` and `message` are the
general entries: an application's samples and ReFrESH's events go through them too. Message
times are the kernel's (or the run's) seconds, logged in nanoseconds from 0.
"""

from __future__ import annotations

import json
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any

from pbort.ports import PortKind, PortSpec
from pbort.trace.recorder import Sample


class JsonChannels(ABC):
    """A sink of channels of JSON messages: a `TraceWriter` of a kernel's samples too."""

    def __init__(self) -> None:
        self._declared: set[str] = set()

    def wants(self, pbo: str) -> bool:
        """Whether a sample of `pbo` would go anywhere (its channel is to be declared, or it
        has a reader)."""
        topic = pbo_topic(pbo)
        return topic not in self._declared or self._read(topic)

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """One message on the PBO's channel: the time and every port."""
        topic = pbo_topic(sample.pbo)
        if topic not in self._declared:
            properties = {port.name: port_schema(port) for port in ports}
            self.channel(topic, f"PBO {sample.pbo}", properties)
        self.message(topic, sample.time, sample.values)

    def channel(
        self, topic: str, title: str, properties: Mapping[str, Any], *, open_ended: bool = False
    ) -> None:
        """Declare a channel whose messages are objects of `properties` (JSON schema), plus the
        time in seconds; `open_ended`: and any other number, named as it comes."""
        schema: dict[str, Any] = {
            "title": title,
            "type": "object",
            "properties": {"time": {"type": "number", "description": "seconds"}, **properties},
        }
        if open_ended:
            schema["additionalProperties"] = {"type": "number"}
        self._declare(topic, title, json.dumps(schema).encode())
        self._declared.add(topic)

    def message(self, topic: str, time: float, values: Mapping[str, Any]) -> None:
        """One message on a declared channel, logged at `time` (seconds, not negative)."""
        if self._read(topic):
            stamp = round(max(time, 0.0) * 1e9)
            self._log(topic, stamp, json.dumps({"time": time, **values}).encode())

    @abstractmethod
    def _declare(self, topic: str, title: str, schema: bytes) -> None:
        """Declare channel `topic` with its schema (JSON schema, named `title`)."""

    @abstractmethod
    def _log(self, topic: str, stamp: int, data: bytes) -> None:
        """Log one JSON message on `topic` at `stamp` nanoseconds."""

    def _read(self, topic: str) -> bool:
        """Whether a message on `topic` has a reader now (a file always does)."""
        return True


def pbo_topic(pbo: str) -> str:
    """The topic of a PBO's channel."""
    return f"/{pbo}"


def port_schema(port: PortSpec) -> dict[str, Any]:
    """A port's value in JSON schema: a number, or nested arrays of numbers."""
    number = {"type": "integer" if port.dtype[1:2] in ("i", "u") else "number"}
    schema: dict[str, Any] = number
    for _ in port.shape if port.kind is not PortKind.SCALAR else ():
        schema = {"type": "array", "items": schema}
    return {**schema, "description": f"{port.direction.value} {port.kind.value} {port.dtype}"}
