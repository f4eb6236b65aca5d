"""The functionality library in Python: the same arithmetic as ``hdl/mx_fn_*.v``.

A functionality is the fixed, data-processing half of a slot. Results are modulo 2^data_w, like
the hardware's truncation. Most map each sample alone (`Function.compute`, with the FIR's and
the running median's history); two work on frames, the beats up to and including one marked
``last``: the 3x3 median holds a row and a pixel before it can emit, the stretch maps each frame
through a table built from the frame before. `FunctionState` is one instance of either kind: a
step takes one beat and returns the beats it emits (0 to n, each with its ``last``); ``reset``
forgets everything, as the wrapper's commit clears the hardware.

A functionality is also a line of text, ``kind:p0:p1`` with as many parameters as its kind has
(``median3x3:160``, ``stretch:10:16``, ``gain:24:3``, ``median5``): `Function.parse` reads it
and ``str`` writes it back, for command lines and module databases.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import IntEnum
from itertools import accumulate
from typing import NamedTuple, Protocol

import numpy as np

from .errors import FabricParameterError


class Kind(IntEnum):
    """Library entries; the values are the Verilog ``KIND`` parameter."""

    PASS = 0
    GAIN = 1
    THRESHOLD = 2
    FIR = 3
    MEDIAN3X3 = 4
    STRETCH = 5
    MEDIAN5 = 6


MEDIAN3X3_MAX_WIDTH = 1024
"""The widest row a 3x3 median takes (``mx_fn_median3x3``'s ``MAX_W``)."""
STRETCH_DATA_W = 8
"""The only sample width the stretch works on (its table has 256 levels)."""
STRETCH_MAX_CLIP = 500
"""The largest clip in permille: half of the frame at each end."""
STRETCH_MAX_SPREAD = 255
STRETCH_COUNT_W = 24
"""Bits of a histogram bin (``mx_fn_stretch``'s ``COUNT_W``): a frame's first 2^24 - 1 beats
count towards its percentiles, the rest are only mapped."""
STRETCH_STALL_CYCLES = 256 + 8 + 256
"""Cycles the stretch holds its input after a frame's ``last``: the scan of the histogram, the
division, the fill of the table."""
STRETCH_CLEAR_CYCLES = 256
"""Cycles the stretch holds its input after reset or a commit: clearing the histogram and
setting the table to the identity."""
LEVELS = 1 << STRETCH_DATA_W
WHITE = LEVELS - 1
MAX_TEXT = 64
"""The longest text `Function.parse` reads: far more than any functionality needs."""


@dataclass(frozen=True)
class Beat:
    """One stream transfer."""

    data: int
    last: bool = False


class _Parameter(NamedTuple):
    """One coefficient of a kind: its name in messages and usage, its range, its notation."""

    name: str
    top: int
    bottom: int = 0
    hexadecimal: bool = False


_WORD = 0xFFFF
_PARAMETERS: dict[Kind, tuple[_Parameter, ...]] = {
    Kind.PASS: (),
    Kind.GAIN: (_Parameter("gain", _WORD), _Parameter("offset", _WORD)),
    Kind.THRESHOLD: (_Parameter("level", _WORD),),
    Kind.FIR: (_Parameter("taps", _WORD, hexadecimal=True), _Parameter("shift", _WORD)),
    Kind.MEDIAN3X3: (_Parameter("width", MEDIAN3X3_MAX_WIDTH, bottom=1),),
    Kind.STRETCH: (
        _Parameter("clip", STRETCH_MAX_CLIP),
        _Parameter("spread", STRETCH_MAX_SPREAD),
    ),
    Kind.MEDIAN5: (),
}
_HISTORY = {Kind.FIR: 3, Kind.MEDIAN5: 4}
"""Previous inputs a sample-by-sample kind remembers (the others remember none)."""
_NUMBER = re.compile(r"0[xX][0-9a-fA-F]{1,8}|[0-9]{1,10}")
"""A parameter as text: decimal or 0x-hexadecimal, short enough to convert at no cost."""


@dataclass(frozen=True)
class Function:
    """One library functionality with its two 16-bit coefficients.

    GAIN: y = ((x * p0) >> 4) + p1 (p0 has four fraction bits);  THRESHOLD: y = x if x >= p0
    else 0;  FIR: y = (c0 x[n] + c1 x[n-1] + c2 x[n-2] + c3 x[n-3]) >> (p1 & 15) with the four
    nibbles of p0 as c0..c3 (c0 lowest);  PASS: y = x;  MEDIAN5: y = the median of x[n] ..
    x[n-4] read as signed data_w-bit integers;  MEDIAN3X3 (p0 the row width, 1..1024): each
    frame's 3x3 median, edges replicated (`Median3x3`);  STRETCH (p0 the clip in permille,
    0..500, p1 the minimum spread, 0..255; 8-bit data only): each frame mapped through the
    stretch the frame before it calls for (`Stretch`). A kind's unused coefficients are 0.
    """

    kind: Kind
    p0: int = 0
    p1: int = 0

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "kind", Kind(self.kind))
        except ValueError:
            raise FabricParameterError(
                f"expected a functionality kind in 0..{max(Kind)}, got {self.kind!r}"
            ) from None
        parameters = _PARAMETERS[self.kind]
        for index, value in enumerate((self.p0, self.p1)):
            if not isinstance(value, int) or isinstance(value, bool):
                raise FabricParameterError(
                    f"expected {_usage(self.kind)} with integers, got p{index}={value!r}"
                )
            if index >= len(parameters):
                if value:
                    raise FabricParameterError(
                        f"expected {_usage(self.kind)} (no p{index}), got p{index}={value}"
                    )
                continue
            parameter = parameters[index]
            if not parameter.bottom <= value <= parameter.top:
                raise FabricParameterError(
                    f"expected {_usage(self.kind)} with {parameter.name.upper()} (p{index}) in "
                    f"{parameter.bottom}..{parameter.top}, got {value}"
                )

    @property
    def name(self) -> str:
        """The kind's name in text: ``median3x3``."""
        return self.kind.name.lower()

    @property
    def holds_beats(self) -> bool:
        """Whether a beat may leave later than the step that took it (the 3x3 median)."""
        return self.kind is Kind.MEDIAN3X3

    @property
    def drain_cycles(self) -> int:
        """Cycles the hardware may take, beyond one a beat, before the beats of a frame whose
        ``last`` it has taken are all out and it takes the next: the 3x3 median's flush (a row
        and a pixel, then its buffer), the stretch's stall (or its clearing after a commit)."""
        if self.kind is Kind.MEDIAN3X3:
            return self.p0 + 3
        if self.kind is Kind.STRETCH:
            return max(STRETCH_STALL_CYCLES, STRETCH_CLEAR_CYCLES)
        return 0

    @classmethod
    def parse(cls, text: str) -> Function:
        """The functionality ``text`` names, ``kind[:p0[:p1]]`` with exactly the kind's
        parameters, each decimal or 0x-hexadecimal; FabricParameterError naming what was
        expected and what came for anything else."""
        if not isinstance(text, str) or len(text) > MAX_TEXT:
            raise FabricParameterError(
                f"expected a functionality as text of at most {MAX_TEXT} characters "
                f"({_USAGE}), got {_shown(text)}"
            )
        name, *fields = text.strip().split(":")
        kind = _KINDS.get(name.strip().lower())
        if kind is None:
            raise FabricParameterError(f"expected a functionality ({_USAGE}), got {_shown(text)}")
        parameters = _PARAMETERS[kind]
        if len(fields) != len(parameters):
            raise FabricParameterError(f"expected {_usage(kind)}, got {_shown(text)}")
        values = [
            _number(field, parameter, kind, text)
            for field, parameter in zip(fields, parameters, strict=True)
        ]
        return cls(kind, *values)

    def __str__(self) -> str:
        """The text `parse` reads back as this functionality: ``gain:24:3``."""
        fields = [  # the kind's parameters, p0 first (an unused one is 0 and not written)
            f"{value:#06x}" if parameter.hexadecimal else str(value)
            for parameter, value in zip(_PARAMETERS[self.kind], (self.p0, self.p1), strict=False)
        ]
        return ":".join([self.name, *fields])

    def check_data_width(self, data_w: int) -> None:
        """Refuse a sample width this functionality cannot be built for (the stretch's table
        has 256 levels: 8 bits, as its Verilog insists)."""
        if self.kind is Kind.STRETCH and data_w != STRETCH_DATA_W:
            raise FabricParameterError(
                f"expected a data width of {STRETCH_DATA_W} bits for {self}, got {data_w}"
            )

    def compute(self, x: int, history: Sequence[int], data_w: int) -> int:
        """The output for input ``x`` of a kind that maps each sample alone; ``history`` is the
        previous inputs, newest first (x[n-1], x[n-2], ...: three for the FIR, four for the
        running median). The frame kinds need a `FunctionState`."""
        mask = (1 << data_w) - 1
        if self.kind is Kind.GAIN:
            return (((x * self.p0) >> 4) + self.p1) & mask
        if self.kind is Kind.THRESHOLD:
            return x if x >= self.p0 else 0
        if self.kind is Kind.FIR:
            taps = [(self.p0 >> (4 * k)) & 0xF for k in range(4)]
            samples = (x, *history[:3])
            total = sum(c * s for c, s in zip(taps, samples, strict=True))
            return (total >> (self.p1 & 0xF)) & mask
        if self.kind is Kind.MEDIAN5:
            window = sorted(_signed(v, data_w) for v in (x, *history[:4]))
            return window[2] & mask
        if self.holds_beats or self.kind is Kind.STRETCH:
            raise FabricParameterError(
                f"expected a functionality that maps each sample alone, got {self}, which maps "
                f"frames (step a FunctionState)"
            )
        return x

    def describe(self) -> str:
        """A short human name, e.g. ``gain(1.5x+3)``."""
        if self.kind is Kind.GAIN:
            return f"gain({self.p0 / 16:g}x+{self.p1})"
        if self.kind is Kind.THRESHOLD:
            return f"threshold(>={self.p0})"
        if self.kind is Kind.FIR:
            return f"fir(taps={self.p0:04x},>>{self.p1 & 0xF})"
        if self.kind is Kind.MEDIAN3X3:
            return f"median3x3(rows of {self.p0})"
        if self.kind is Kind.STRETCH:
            return f"stretch(clip {self.p0}/1000,spread>={self.p1})"
        return self.name


_KINDS = {kind.name.lower(): kind for kind in Kind}


def _usage(kind: Kind) -> str:
    """How a kind is written: ``gain:GAIN:OFFSET``."""
    return ":".join([kind.name.lower(), *(p.name.upper() for p in _PARAMETERS[kind])])


_USAGE = "one of " + ", ".join(_usage(kind) for kind in Kind)


def _number(field: str, parameter: _Parameter, kind: Kind, whole: str) -> int:
    """One parameter's text as an integer (its range is `Function`'s to check); ``whole`` is
    the functionality's text, for the message."""
    text = field.strip()
    if not _NUMBER.fullmatch(text):
        raise FabricParameterError(
            f"expected {_usage(kind)} with {parameter.name.upper()} a number in "
            f"{parameter.bottom}..{parameter.top}, got {_shown(whole)}"
        )
    return int(text[2:], 16) if text[:2].lower() == "0x" else int(text)


def _shown(value: object) -> str:
    """A value as an error message shows it: escaped and bounded."""
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."


def _signed(value: int, data_w: int) -> int:
    """``value``'s data_w bits read as two's complement."""
    return value - (1 << data_w) if value >> (data_w - 1) & 1 else value


def check_data_width(functions: Sequence[Function], data_w: int) -> None:
    """Refuse a sample width one of ``functions`` cannot be built for (a fabric's check)."""
    for function in functions:
        function.check_data_width(data_w)


class _Core(Protocol):
    """What a `FunctionState` runs: one beat in, the beats it emits out."""

    def step(self, beat: Beat) -> list[Beat]: ...

    def frame(self, data: list[int]) -> list[int]: ...


class _Samples:
    """A kind that maps each sample alone, with the inputs its history needs."""

    def __init__(self, function: Function, data_w: int) -> None:
        self.function = function
        self.data_w = data_w
        self.history = (0,) * _HISTORY.get(function.kind, 0)

    def step(self, beat: Beat) -> list[Beat]:
        x = beat.data
        y = self.function.compute(x, self.history, self.data_w)
        if self.history:
            self.history = (x, *self.history[:-1])
        return [Beat(y, beat.last)]

    def frame(self, data: list[int]) -> list[int]:
        """A frame's beats (its last one the frame's last): what `step` gives them, one by
        one; a map with no history in one numpy operation."""
        kind = self.function.kind
        if kind in _VECTORIZED and len(data) >= NUMPY_FROM:
            return _VECTORIZED[kind](self.function, np.asarray(data, np.int64), self.data_w)
        if not self.history:
            return [self.function.compute(x, (), self.data_w) for x in data]
        return [self.step(Beat(x, k == len(data) - 1))[0].data for k, x in enumerate(data)]


class Median3x3:
    """The 3x3 median of each frame, as ``mx_fn_median3x3`` emits it.

    Beat i of a frame is pixel (i // width, i % width); the frame's last row may be partial.
    Output i is the median of the nine positions around pixel i, each taken from the nearest
    pixel of the frame: its row clamped into the frame's rows, then its column clamped into that
    row's pixels. Output i leaves with input i + width + 1 (the position below and to the right,
    in raster order); the frame's ``last`` releases every output still held, the last one
    marked. It keeps only the rows an output still needs.
    """

    def __init__(self, function: Function, data_w: int) -> None:
        self.width = function.p0
        self._new_frame()

    def _new_frame(self) -> None:
        self.pixels: list[int] = []  # the frame's beats from `base` on
        self.base = 0
        self.arrived = 0
        self.emitted = 0

    def step(self, beat: Beat) -> list[Beat]:
        self.pixels.append(beat.data)
        self.arrived += 1
        if beat.last:
            out = [
                self._output(k, k == self.arrived - 1) for k in range(self.emitted, self.arrived)
            ]
            self._new_frame()
            return out
        if self.arrived <= self.width + 1:
            return []
        out = [self._output(self.emitted)]
        self.emitted += 1
        self._forget()
        return out

    def frame(self, data: list[int]) -> list[int]:
        """A frame's beats (its last one the frame's last): what `step` gives them; a frame of
        whole rows taken at a frame's start at once, with numpy (the reference's rule for
        whole rows is np.pad's edge mode)."""
        if self.arrived or not data or len(data) % self.width:
            return [
                b.data for k, x in enumerate(data) for b in self.step(Beat(x, k == len(data) - 1))
            ]
        rows = len(data) // self.width
        image = np.asarray(data, np.int64).reshape(rows, self.width)
        padded = np.pad(image, 1, mode="edge")
        around = np.stack(
            [padded[dr : dr + rows, dc : dc + self.width] for dr in range(3) for dc in range(3)]
        )
        return np.sort(around, axis=0)[4].ravel().tolist()

    def _output(self, index: int, last: bool = False) -> Beat:
        row, column = divmod(index, self.width)
        around = sorted(
            self._pixel(row + dr, column + dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)
        )
        return Beat(around[4], last)

    def _pixel(self, row: int, column: int) -> int:
        """The pixel nearest to (row, column) among those arrived."""
        rows = -(-self.arrived // self.width)
        row = min(max(row, 0), rows - 1)
        column = min(max(column, 0), self.width - 1, self.arrived - 1 - row * self.width)
        return self.pixels[row * self.width + column - self.base]

    def _forget(self) -> None:
        """Drop the rows above the next output's (it needs one above it), a row at a time."""
        keep = max(0, (self.emitted // self.width - 1) * self.width)
        if keep - self.base >= self.width:
            del self.pixels[: keep - self.base]
            self.base = keep


class Stretch:
    """The contrast stretch of ``mx_fn_stretch``: each frame mapped through the table the frame
    before it calls for (the identity before the first), `last` passed through.

    At a frame's ``last``, of its n counted beats (the first 2^24 - 1), low and high are the
    levels of rank n * clip // 1000 and n - 1 - that; the next table is `stretch_table`.
    """

    def __init__(self, function: Function, data_w: int) -> None:
        self.clip = function.p0
        self.min_spread = function.p1
        self.table = tuple(range(LEVELS))
        self.counts = [0] * LEVELS
        self.counted = 0

    def step(self, beat: Beat) -> list[Beat]:
        out = Beat(self.table[beat.data], beat.last)
        if self.counted < (1 << STRETCH_COUNT_W) - 1:
            self.counts[beat.data] += 1
            self.counted += 1
        if beat.last:
            self.table = stretch_table(*self._percentiles(), self.min_spread)
            self.counts = [0] * LEVELS
            self.counted = 0
        return [out]

    def frame(self, data: list[int]) -> list[int]:
        """A frame's beats (its last one the frame's last): what `step` gives them, mapped and
        counted with numpy while the frame stays under the count's limit."""
        if not data or self.counted + len(data) > (1 << STRETCH_COUNT_W) - 1:
            return [self.step(Beat(x, k == len(data) - 1))[0].data for k, x in enumerate(data)]
        levels = np.asarray(data, np.int64)
        out = np.asarray(self.table, np.int64)[levels].tolist()
        self.counts = (np.asarray(self.counts) + np.bincount(levels, minlength=LEVELS)).tolist()
        self.counted += len(data)
        self.table = stretch_table(*self._percentiles(), self.min_spread)
        self.counts = [0] * LEVELS
        self.counted = 0
        return out

    def _percentiles(self) -> tuple[int, int]:
        """The levels of rank n * clip // 1000 and n - 1 - that, from the histogram."""
        rank = self.counted * self.clip // 1000
        below = list(accumulate(self.counts))  # below[level]: beats at or below level
        return bisect_right(below, rank), bisect_right(below, self.counted - 1 - rank)


def stretch_table(low: int, high: int, min_spread: int) -> tuple[int, ...]:
    """The 256-entry table that stretches [low, high] onto [0, 255]: levels up to low map to 0,
    from high on to 255, between to ((x - low) * 255 + spread // 2) // spread; the identity
    when high - low < min_spread (the Dehazer's table, with its MIN_SPREAD a parameter)."""
    spread = high - low
    if spread < min_spread:
        return tuple(range(LEVELS))
    return tuple(
        0 if x <= low else WHITE if x >= high else ((x - low) * WHITE + spread // 2) // spread
        for x in range(LEVELS)
    )


def _gain(function: Function, x: np.ndarray, data_w: int) -> list[int]:
    return ((((x * function.p0) >> 4) + function.p1) & ((1 << data_w) - 1)).tolist()


def _threshold(function: Function, x: np.ndarray, data_w: int) -> list[int]:
    return np.where(x >= function.p0, x, 0).tolist()


def _pass(function: Function, x: np.ndarray, data_w: int) -> list[int]:
    return x.tolist()


NUMPY_FROM = 64
"""Beats from which a stateless map goes through numpy: below, converting costs more than it
saves (a node's fabric PBO sends one sample a call)."""

_VECTORIZED: dict[Kind, Callable[[Function, np.ndarray, int], list[int]]] = {
    Kind.GAIN: _gain,
    Kind.THRESHOLD: _threshold,
    Kind.PASS: _pass,
}
"""The kinds that map each sample alone, with no history: a frame in one numpy operation."""

_FRAME_CORES: dict[Kind, type[Median3x3] | type[Stretch]] = {
    Kind.MEDIAN3X3: Median3x3,
    Kind.STRETCH: Stretch,
}


class FunctionState:
    """A functionality instance: the function plus what it remembers between beats (the FIR's
    and the running median's history, the 3x3 median's rows, the stretch's histogram and
    table)."""

    def __init__(self, function: Function, data_w: int) -> None:
        function.check_data_width(data_w)
        self.function = function
        self.data_w = data_w
        self.reset()

    def reset(self) -> None:
        """Forget everything (the wrapper's commit clears the hardware alike)."""
        core = _FRAME_CORES.get(self.function.kind, _Samples)
        self._core: _Core = core(self.function, self.data_w)
        self.step: Callable[[Beat], list[Beat]] = self._core.step
        """Process one accepted beat; the beats the functionality emits with it, in order
        (the core's own method: a node's loop calls it for every beat)."""
        self.frame: Callable[[list[int]], list[int]] = self._core.frame
        """Process a frame's beats at once, its last one marked ``last``: the beats it emits,
        exactly what `step` gives beat by beat (the model's `stream` takes whole frames, a
        camera frame through a 3x3 median and a stretch in numpy rather than a Python step per
        pixel)."""


def default_library(n: int, data_w: int) -> tuple[Function, ...]:
    """The functionalities the tests and benchmarks build: gain, threshold, FIR, pass, repeated.

    Coefficients differ from slot to slot so a beat that takes a wrong route shows.
    """
    half = 1 << (data_w - 1)
    cycle = (
        lambda i: Function(Kind.GAIN, 24 + i, 3 + i),
        lambda i: Function(Kind.THRESHOLD, min(half + i, 0xFFFF)),
        lambda i: Function(Kind.FIR, 0x1331 + 0x0101 * (i % 3), 3),
        lambda i: Function(Kind.PASS),
    )
    return tuple(cycle[i % 4](i) for i in range(n))
