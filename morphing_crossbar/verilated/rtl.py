"""The crossbar's Verilog in the node's loop: `RtlCrossbarModel`, the model library
(`morphing_crossbar.verilated.build`) driven through ctypes.

It answers what the transaction-level model answers (`morphing_crossbar.model.CrossbarModel`):
`load` a partial bitstream into a slot, `stream` beats through the external inputs; but the
beats cross the RTL, clock by clock, in C: one call per batch, millions of fabric cycles a second
(`benchmarks/crossbar.py`), and one beat (a node's fabric PBO sends one a cycle) through a call of
its own that needs no arrays. The inputs and the routing are checked in Python first, as the TLM
checks them (`checked_inputs`; a frame the wrapper must refuse is refused with the same error
before it is shifted in, an input with no route to an output raises `RouteError`), so the RTL
only ever meets what it must carry; a model that still does not deliver within its cycle bound,
delivers where the routing takes nothing, or judges a frame otherwise than the Python decoder
raises `FabricStallError`: a disagreement between the two, never a hang.

A model is used by one call at a time (a lock: ctypes lets other threads run during a C call);
after a stall, or `close`, every call raises `ModelUnusableError` instead of driving a design
whose state no longer matches the Python side's (or freed memory).
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Mapping, Sequence
from itertools import accumulate
from pathlib import Path

import numpy as np

from ..bitstream import decode_bytes, word_to_beats
from ..errors import FabricStallError, ModelBuildError, ModelUnusableError
from ..fabric import Fabric
from ..model import LoadResult, checked_inputs
from ..routing import Configuration, SlotRoute
from .build import fabric_digest

CYCLES_PER_BEAT = 8
"""Cycles a batch may take per beat before the model is said to stall (one a beat, and the
pipeline's depth, spread over the batch)."""
PIPELINE_SLACK = 1000
"""Cycles a batch or a reconfiguration may take beyond that (a route through every slot); a batch
may also take what the fabric's functionalities take at a frame's end (`Function.drain_cycles`:
the 3x3 median's flush, the stretch's stall)."""
STALLED = -1
"""What the driver's calls return when their cycle bound passed first (-2: a beat left where the
routing takes none; `mx_model.cpp`)."""

_POINTER = ctypes.c_void_p


class RtlCrossbarModel:
    """One fabric's RTL, built into `library` (`model_library`), from reset."""

    def __init__(self, fabric: Fabric, library: Path) -> None:
        self.fabric = fabric
        self.configuration = Configuration.reset(fabric)
        self._handle: int | None = None
        self._unusable = ""  # why calls are refused, once they are
        self._lock = threading.Lock()
        try:
            self._lib = _bind(ctypes.CDLL(str(library)))
        except (OSError, AttributeError) as error:  # not a library, or not this driver's
            raise ModelBuildError(
                f"cannot load the fabric's model {library}: {error} (remove it to rebuild it)"
            ) from None
        _check_fabric(self._lib, fabric, library)
        self._drain = sum(f.drain_cycles for f in fabric.functions)
        self._offsets = np.zeros(fabric.n + 1, dtype=np.int64)
        self._out_offsets = np.zeros(fabric.n + 1, dtype=np.int64)
        self._grow(1)  # the beats in and out, and the arrays' addresses for mx_stream
        self._handle = self._lib.mx_new()

    @property
    def cycles(self) -> int:
        """Fabric clock cycles run since reset."""
        with self._lock:
            return int(self._lib.mx_cycles(self._usable()))

    def load(self, slot: int, frame: bytes) -> LoadResult:
        """Apply a partial bitstream held as bytes to `slot` (raises what the wrapper refuses);
        a route the rest of the routing cannot take with it (a source taken twice) is refused
        first, as the TLM does, then the frame's beats are shifted into the slot's wrapper and
        the commit awaited."""
        route = decode_bytes(self.fabric, slot, frame)
        beats = word_to_beats(int.from_bytes(frame, "big"), 8 * len(frame), self.fabric.cfg_w)
        with self._lock:
            handle = self._usable()
            configuration = self.configuration.with_route(slot, route)
            return self._commit(handle, configuration, slot, route, beats)

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Stream each external input's beats (the last one marked ``last``) through the fabric
        at once; each output port's beats, in order, by port. What the TLM refuses is refused
        alike before any beat (`checked_inputs`, then an input routed to no output)."""
        inputs = checked_inputs(self.fabric, inputs)
        with self._lock:
            handle = self._usable()
            outputs = self.configuration.require_routes(inputs)
            if len(inputs) == 1:
                ((port, beats),) = inputs.items()
                if len(beats) == 1:
                    return {outputs[port]: [self._beat(handle, port, beats[0], outputs[port])]}
            return self._batch(handle, inputs, outputs)

    def close(self) -> None:
        """Free the model (later calls raise ModelUnusableError); calling it twice does
        nothing."""
        with self._lock:
            handle, self._handle = self._handle, None
            if handle is not None:
                self._unusable = "the fabric's RTL model was closed"
                self._lib.mx_free(handle)

    def __del__(self) -> None:
        self.close()

    def _usable(self) -> int:
        """The driver's handle; ModelUnusableError once closed or after a stall."""
        if self._unusable:
            raise ModelUnusableError(self._unusable)
        assert self._handle is not None  # set whenever the model is usable
        return self._handle

    def _stalled(self, said: str) -> FabricStallError:
        """`said` as the error to raise, the model marked unusable from now on."""
        self._unusable = f"the fabric's RTL model is unusable since an earlier call: {said}"
        return FabricStallError(said)

    def _beat(self, handle: int, port: int, data: int, output: int) -> int:
        """One beat into `port`, out of `output` (the node's loop: no arrays)."""
        limit = CYCLES_PER_BEAT + PIPELINE_SLACK + self._drain
        got = self._lib.mx_beat(handle, port, data, output, limit)
        if got < 0:
            raise self._stalled(_disagreement(got, 1, limit))
        return int(got)

    def _batch(
        self, handle: int, inputs: dict[int, list[int]], outputs: dict[int, int]
    ) -> dict[int, list[int]]:
        """Every input's beats at once, in reused arrays (grown when a batch needs more)."""
        n = self.fabric.n
        counts, out_counts = [0] * n, [0] * n
        for port, beats in inputs.items():
            counts[port] = out_counts[outputs[port]] = len(beats)
        starts = list(accumulate(counts, initial=0))
        out_starts = list(accumulate(out_counts, initial=0))
        self._offsets[:] = starts
        self._out_offsets[:] = out_starts
        count = starts[n]
        if count > len(self._data):
            self._grow(count)
        for port, beats in inputs.items():
            self._data[starts[port] : starts[port + 1]] = beats
        limit = CYCLES_PER_BEAT * count + PIPELINE_SLACK + self._drain
        got = self._lib.mx_stream(handle, *self._arrays, limit)
        if got < 0:
            raise self._stalled(_disagreement(got, count, limit))
        return {
            output: self._out[out_starts[output] : out_starts[output + 1]].tolist()
            for port, output in outputs.items()
            if inputs[port]
        }

    def _grow(self, count: int) -> None:
        """Room for `count` beats in and out; the arrays' addresses kept (reading them is most
        of a small batch's cost)."""
        self._data = np.zeros(count, dtype=np.uint32)
        self._out = np.zeros(count, dtype=np.uint32)
        arrays = (self._offsets, self._data, self._out_offsets, self._out)
        self._arrays: tuple[int, ...] = tuple(array.ctypes.data for array in arrays)

    def _commit(
        self,
        handle: int,
        configuration: Configuration,
        slot: int,
        route: SlotRoute,
        beats: list[int],
    ) -> LoadResult:
        """Shift `beats` into `slot`'s wrapper and wait for its commit; `configuration` is the
        routing once it committed."""
        words = np.asarray(beats, dtype=np.uint32)
        code = ctypes.c_int32(-1)
        cycles = self._lib.mx_configure(
            handle, slot, words.ctypes.data, len(beats), ctypes.byref(code), PIPELINE_SLACK
        )
        if cycles < 0:
            raise self._stalled(
                f"slot {slot}: the RTL gave no verdict in {PIPELINE_SLACK} cycles on a frame "
                f"the decoder accepts"
            )
        if code.value != 0:  # refused: the wrapper keeps its routing, as the Python side does
            raise FabricStallError(
                f"slot {slot}: the RTL answered error code {code.value} to a frame the decoder "
                f"accepts"
            )
        self.configuration = configuration
        return LoadResult(slot, route, int(cycles))


def _disagreement(got: int, count: int, limit: int) -> str:
    """What a failed `mx_stream` or `mx_beat` means."""
    if got == STALLED:
        return f"the RTL delivered fewer than {count} beats in {limit} cycles"
    return "the RTL delivered a beat at an output the routing takes none to (or one too many)"


def _check_fabric(lib: ctypes.CDLL, fabric: Fabric, library: Path) -> None:
    """Refuse a library built for another fabric (its driver would write past the design's
    ports, or compute other functions)."""
    shape = (ctypes.c_uint64 * 4)()
    lib.mx_fabric(shape)
    expected = (fabric.n, fabric.data_w, fabric.cfg_w, fabric_digest(fabric))
    if tuple(shape) != expected:
        raise ModelBuildError(
            f"cannot drive {library} as this fabric: expected a library built for "
            f"{_describe(*expected)}, got one for {_describe(*shape)}"
        )


def _describe(n: int, data_w: int, cfg_w: int, digest: int) -> str:
    return f"N={n}, DATA_W={data_w}, CFG_W={cfg_w} (parameters {digest:016x})"


def _bind(lib: ctypes.CDLL) -> ctypes.CDLL:
    """`lib`'s functions with their C signatures (`mx_model.cpp`)."""
    lib.mx_fabric.restype = None
    lib.mx_fabric.argtypes = [_POINTER]
    lib.mx_new.restype = _POINTER
    lib.mx_new.argtypes = []
    lib.mx_free.restype = None
    lib.mx_free.argtypes = [_POINTER]
    lib.mx_cycles.restype = ctypes.c_uint64
    lib.mx_cycles.argtypes = [_POINTER]
    lib.mx_stream.restype = ctypes.c_int64
    lib.mx_stream.argtypes = [
        _POINTER, _POINTER, _POINTER, _POINTER, _POINTER, ctypes.c_uint64,
    ]  # fmt: skip
    lib.mx_beat.restype = ctypes.c_int64
    lib.mx_beat.argtypes = [_POINTER, ctypes.c_int, ctypes.c_uint32, ctypes.c_int, ctypes.c_uint64]
    lib.mx_configure.restype = ctypes.c_int64
    lib.mx_configure.argtypes = [
        _POINTER, ctypes.c_int, _POINTER, ctypes.c_int64, _POINTER, ctypes.c_uint64,
    ]  # fmt: skip
    return lib
