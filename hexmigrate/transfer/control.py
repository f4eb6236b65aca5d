"""Node control over the node's own link: what a receiver needs of a node to list, start, stop,
set, wire and read its PBOs, and how the answers' contents travel.

A `ControlTarget` is the node side (firmware_sim's `NodeTarget` implements it on its kernel);
every operation that cannot be done raises an exception whose text says why, naming the PBO,
port or constant, which the receiver sends back as a refusal. Values cross the wire as numbers
(int or float) of scalar ports only: a vector or frame port is refused by name.

The answers carry words of free text, one per PBO (`PboRow`) or per port value, which
`rows_text`/`parse_rows` and `values_text`/`parse_values` write and read on both sides; an
`Advance` and its answer carry ``NUMBER=COUNT`` words per bridge (`counts_text`/`parse_counts`),
the answer after the word ``advanced`` and the node's clock in microseconds (`advanced_text`/
`parse_advanced`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple, Protocol

from hexmigrate.errors import MessageError

Number = int | float

MAX_PORTS = 32
"""The most ports one READ or WATCH names: a node reads each of them for the answer, or for
every report of a watch, so a longer list only floods the node and its line."""
MAX_BRIDGES = 256
"""The most bridges one ADVANCE or its answer names."""
ADVANCED = "advanced"
"""The first word of the answer to an Advance."""
MICROSECONDS = 1_000_000
MAX_ADVANCE = 3600.0
"""The most seconds of virtual time one Advance moves a clock: a node answers nothing while it
runs, a time master grants quanta far shorter, and a device that follows the time stamped on
what it is sent (the lock-step servos) moves no further at once."""
BRIDGE_NUMBERS = 1 << 16
"""Bridge numbers travel as u16."""
MAX_LOG_TEXT = 800
"""Characters of log lines one answer carries at most: a text-mode line holds 1,024, and a
follower asks again from the last line it got."""
MAX_LOG_LINE = 512
"""Characters of one logged line a host takes (a node keeps no more)."""


class LoggedLine(NamedTuple):
    """A line a PBO's module logged, as it travels: its number in the PBO's log (from 1), the
    node's clock when it was logged (seconds) and the module's text."""

    number: int
    time: float
    text: str


@dataclass(frozen=True)
class PboRow:
    """One PBO of a node: its name, lifecycle state, rate (Hz; None: aperiodic) and its ports
    by direction (names only)."""

    name: str
    state: str
    rate: float | None
    inputs: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()
    constants: tuple[str, ...] = ()

    def word(self) -> str:
        """``NAME:STATE:RATE:IN,..:OUT,..:CONST,..`` (RATE ``-`` when aperiodic)."""
        rate = "-" if self.rate is None else f"{self.rate:g}"
        ports = (",".join(names) for names in (self.inputs, self.outputs, self.constants))
        return ":".join((self.name, self.state, rate, *ports))

    @classmethod
    def parse(cls, word: str) -> PboRow:
        """A row from its `word`; MessageError when it is not one."""
        parts = word.split(":")
        if len(parts) != 6 or not parts[0] or not parts[1]:
            raise MessageError(f"expected NAME:STATE:RATE:IN:OUT:CONST, got {word[:60]!r}")
        name, state, rate, inputs, outputs, constants = parts
        return cls(
            name,
            state,
            None if rate == "-" else _finite(rate),
            _names(inputs),
            _names(outputs),
            _names(constants),
        )


@dataclass(frozen=True)
class PboDetail:
    """What a node says of one PBO beyond its `PboRow`: each constant's value (a scalar's
    number, else its kind), each wire into or out of it (``OUT_PBO.port=IN_PBO.port``) and the
    last failure of its methods (None: none yet)."""

    name: str
    constants: tuple[tuple[str, Number | str], ...] = ()
    wires: tuple[str, ...] = ()
    last_failure: str | None = None


def description_text(detail: PboDetail) -> str:
    """`detail` as one JSON object of printable ASCII, cut to MAX_LOG_TEXT characters by
    dropping wires, then constants, then the failure's end (a line holds 1,024)."""
    fields = {
        "name": detail.name,
        "constants": [list(pair) for pair in detail.constants],
        "wires": list(detail.wires),
        "last_failure": detail.last_failure,
    }
    while len(json.dumps(fields)) > MAX_LOG_TEXT:
        if fields["wires"]:
            fields["wires"].pop()  # type: ignore[attr-defined]
        elif fields["constants"]:
            fields["constants"].pop()  # type: ignore[attr-defined]
        else:
            fields["last_failure"] = str(fields["last_failure"])[:200]
            break
    return json.dumps(fields)


def parse_description(text: str) -> PboDetail:
    """A `PboDescription`'s detail; MessageError for anything but `description_text`'s form."""
    try:
        raw = json.loads(_printable(text))
        constants = tuple((str(n), v) for n, v in raw["constants"] if _is_value(v))
        wires = tuple(str(wire) for wire in raw["wires"])
        failure = raw["last_failure"]
        detail = PboDetail(
            str(raw["name"]), constants, wires, None if failure is None else str(failure)
        )
    except (ValueError, KeyError, TypeError, RecursionError):
        raise MessageError(f"expected a PBO's description, got {text[:60]!r}") from None
    return detail


def _is_value(value: object) -> bool:
    return isinstance(value, (int, float, str)) and not isinstance(value, bool)


class ControlTarget(Protocol):
    """The node a receiver controls."""

    def pbos(self) -> tuple[PboRow, ...]: ...
    def start(self, name: str) -> str: ...
    def stop(self, name: str) -> str: ...
    def set_constant(self, setting: str) -> str: ...
    def set_rate(self, name: str, hertz: float) -> str: ...
    def connect(self, source: str, sink: str) -> str: ...
    def disconnect(self, source: str, sink: str) -> str: ...
    def read(self, port: str) -> Number: ...
    def log(self, name: str, since: int) -> tuple[int, tuple[LoggedLine, ...]]: ...
    def clear(self, name: str) -> str: ...
    def hold(self, name: str) -> str: ...
    def reset(self) -> str: ...
    def describe(self, name: str) -> PboDetail: ...
    def clock(self) -> float: ...
    def performance(self, since: float) -> tuple[tuple[str, Number], ...]: ...
    def state(self) -> str: ...
    def export_port(self, number: int, source: str, url: str, wire: str, rate: int) -> str: ...
    def import_port(self, number: int, sink: str, url: str, wire: str, rate: int) -> str: ...
    def advance(
        self, until: float, expect: Mapping[int, int]
    ) -> tuple[float, Mapping[int, int]]: ...


def wire(text: str) -> tuple[str, str]:
    """``OUT_PBO.port=IN_PBO.port`` as (source, sink); MessageError when it is not of that form."""
    source, found, sink = text.partition("=")
    if not (found and _is_port(source) and _is_port(sink)):
        raise MessageError(f"expected OUT_PBO.port=IN_PBO.port, got {text[:60]!r}")
    return source, sink


def port(text: str) -> str:
    """A ``PBO.port`` word; MessageError when it is not one."""
    if not _is_port(text):
        raise MessageError(f"expected a PBO.port, got {text[:60]!r}")
    return text


def ports(text: str) -> tuple[str, ...]:
    """The ``PBO.port`` words of a read request; MessageError when one is not, none come or
    more than MAX_PORTS."""
    names = tuple(text.split(maxsplit=MAX_PORTS))
    if len(names) > MAX_PORTS:
        raise MessageError(f"expected at most {MAX_PORTS} ports, got more")
    bad = [name for name in names if not _is_port(name)]
    if bad or not names:
        got = repr(bad[0][:60]) if bad else "none"
        raise MessageError(f"expected PBO.port names, got {got}")
    return names


def rows_text(rows: tuple[PboRow, ...]) -> str:
    """The free text of a PBO listing."""
    return " ".join(row.word() for row in rows)


def parse_rows(text: str) -> tuple[PboRow, ...]:
    """A PBO listing from its free text."""
    return tuple(PboRow.parse(word) for word in _printable(text).split())


def values_text(values: tuple[tuple[str, Number], ...]) -> str:
    """The free text of named values (ports, evaluator outputs): ``NAME=VALUE`` words (a float
    as Python's repr, so it reads back the same)."""
    return " ".join(f"{port}={value!r}" for port, value in values)


def parse_values(text: str) -> tuple[tuple[str, Number], ...]:
    """Named values from their free text."""
    values = []
    for word in _printable(text).split():
        port, found, value = word.partition("=")
        if not (found and port):
            raise MessageError(f"expected NAME=VALUE, got {word[:60]!r}")
        values.append((port, _number(value)))
    return tuple(values)


def log_text(lines: Sequence[LoggedLine], budget: int) -> str:
    """The oldest of `lines` whose text fits `budget` characters, as one JSON array of
    ``[NUMBER, MICROSECONDS, TEXT]``: printable ASCII whatever a module wrote (JSON escapes
    control characters and ``ensure_ascii`` the rest), and one line at least, cut to fit."""
    taken: list[list[object]] = []
    for line in lines:
        entry = [line.number, round(line.time * MICROSECONDS), line.text]
        if taken and len(json.dumps([*taken, entry])) > budget:
            break
        taken.append(entry)
        while len(json.dumps(taken)) > budget and len(str(taken[-1][2])) > 1:
            text = str(taken[-1][2])
            taken[-1][2] = text[: len(text) // 2]
    return json.dumps(taken) if taken else ""


def parse_log(text: str) -> tuple[LoggedLine, ...]:
    """The lines of a `LogLines` answer; MessageError for anything but `log_text`'s form."""
    if not text.strip():
        return ()
    try:
        raw = json.loads(_printable(text))
    except (ValueError, RecursionError):
        raise MessageError(f"expected a JSON array of log lines, got {text[:60]!r}") from None
    if not isinstance(raw, list):
        raise MessageError(f"expected a JSON array of log lines, got {text[:60]!r}")
    return tuple(_log_line(entry) for entry in raw)


def _log_line(entry: object) -> LoggedLine:
    if (
        not isinstance(entry, list)
        or len(entry) != 3
        or not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in entry[:2])
        or not isinstance(entry[2], str)
    ):
        raise MessageError(f"expected [NUMBER, MICROSECONDS, TEXT], got {str(entry)[:60]!r}")
    number, micros, text = entry
    return LoggedLine(number, micros / MICROSECONDS, text[:MAX_LOG_LINE])


def counts_text(counts: Mapping[int, int]) -> str:
    """``NUMBER=COUNT`` words, one per bridge."""
    return " ".join(f"{number}={count}" for number, count in counts.items())


def parse_counts(text: str) -> dict[int, int]:
    """{bridge number: count} from ``NUMBER=COUNT`` words; MessageError when a word is not one,
    a number repeats or more than MAX_BRIDGES come."""
    words = _printable(text).split(maxsplit=MAX_BRIDGES)
    if len(words) > MAX_BRIDGES:
        raise MessageError(f"expected at most {MAX_BRIDGES} bridges, got more")
    counts: dict[int, int] = {}
    for word in words:
        number, found, count = word.partition("=")
        if not (found and number.isdigit() and count.isdigit()):
            raise MessageError(f"expected NUMBER=COUNT, got {word[:60]!r}")
        if int(number) >= BRIDGE_NUMBERS or int(number) in counts:
            raise MessageError(f"expected distinct bridge numbers 0..65535, got {word[:60]!r}")
        counts[int(number)] = int(count)
    return counts


def advanced_text(clock: float, counts: Mapping[int, int]) -> str:
    """The text of an Advance's answer: ``advanced CLOCK_US NUMBER=COUNT ...``."""
    return " ".join([ADVANCED, str(round(clock * MICROSECONDS)), counts_text(counts)]).strip()


def parse_advanced(text: str) -> tuple[float, dict[int, int]]:
    """(the node's clock in seconds, its exports' counts) from an Advance's answer."""
    words = _printable(text).split(None, 2)
    if len(words) < 2 or words[0] != ADVANCED or not words[1].isdigit():
        raise MessageError(f"expected {ADVANCED} CLOCK_US NUMBER=COUNT ..., got {text[:60]!r}")
    return int(words[1]) / MICROSECONDS, parse_counts(words[2] if len(words) > 2 else "")


def _printable(text: str) -> str:
    """`text` when it is printable ASCII words; MessageError otherwise. What a host prints of a
    node's answer must not carry control characters (a terminal's escape sequences)."""
    if not text.isascii() or not all(word.isprintable() for word in text.split()):
        raise MessageError(f"expected printable ASCII words, got {text[:60]!r}")
    return text


def _is_port(text: str) -> bool:
    pbo, dot, port = text.partition(".")
    return bool(dot and pbo and port and "." not in port and "=" not in text)


def _names(text: str) -> tuple[str, ...]:
    return tuple(name for name in text.split(",") if name)


def _number(text: str) -> Number:
    try:
        return int(text)
    except ValueError:
        return _finite(text)


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise MessageError(f"expected a number, got {text[:30]!r}") from None
    if not math.isfinite(value):
        raise MessageError(f"expected a finite number, got {text[:30]!r}")
    return value
