"""The crossbar's Verilog in the node's loop: `RtlCrossbarModel`, the model library
(`morphing_crossbar.verilated.build`) driven in batches through ctypes.

It answers what the transaction-level model answers (`morphing_crossbar.model.CrossbarModel`):
`load` a partial bitstream into a slot, `stream` beats through the external inputs; but the
beats cross the RTL, clock by clock, in C: one call per batch, millions of fabric cycles a second
(`benchmarks/crossbar.py`). The routing is checked in Python first, as the TLM checks it (a
frame the wrapper must refuse is refused with the same error before it is shifted in, an input
with no route to an output raises `RouteError`), so the RTL only ever meets what it must carry;
a model that still does not deliver within its cycle bound (or that judges a frame otherwise than
the Python decoder) raises `FabricStallError`: a disagreement between the two, never a hang.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..bitstream import beats_to_word, decode_bytes, decode_frame, word_to_beats
from ..errors import DataWidthError, FabricStallError, ModelBuildError
from ..fabric import Fabric
from ..model import LoadResult
from ..routing import Configuration, SlotRoute

CYCLES_PER_BEAT = 8
"""Cycles a batch may take per beat before the model is said to stall (one a beat, and the
pipeline's depth, spread over the batch)."""
PIPELINE_SLACK = 1000
"""Cycles a batch or a reconfiguration may take beyond that (a route through every slot)."""

_POINTER = ctypes.c_void_p


class RtlCrossbarModel:
    """One fabric's RTL, built into `library` (`model_library`), from reset."""

    def __init__(self, fabric: Fabric, library: Path) -> None:
        self.fabric = fabric
        self.configuration = Configuration.reset(fabric)
        self.loads = 0
        self._handle: int | None = None
        try:
            self._lib = _bind(ctypes.CDLL(str(library)))
        except (OSError, AttributeError) as error:  # not a library, or not this driver's
            raise ModelBuildError(
                f"cannot load the fabric's model {library}: {error} (remove it to rebuild it)"
            ) from None
        self._handle = self._lib.mx_new(fabric.n, fabric.data_w)

    @property
    def cycles(self) -> int:
        """Fabric clock cycles run since reset."""
        return int(self._lib.mx_cycles(self._handle))

    def load(self, slot: int, frame: bytes) -> LoadResult:
        """Apply a partial bitstream held as bytes to `slot` (raises what the wrapper refuses)."""
        route = decode_bytes(self.fabric, slot, frame)
        beats = word_to_beats(int.from_bytes(frame, "big"), 8 * len(frame), self.fabric.cfg_w)
        return self._commit(slot, route, beats)

    def load_beats(self, slot: int, beats: list[int]) -> LoadResult:
        """Apply a partial bitstream as the configuration port beats that carry it."""
        cfg_w = self.fabric.cfg_w
        route = decode_frame(self.fabric, slot, beats_to_word(beats, cfg_w), len(beats) * cfg_w)
        return self._commit(slot, route, beats)

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Stream each external input's beats (the last one marked ``last``) through the fabric
        at once; each output port's beats, in order, by port."""
        count = sum(len(beats) for beats in inputs.values())
        self.configuration.require_routes(inputs)
        for beats in inputs.values():
            _check_widths(self.fabric, beats)
        offsets = np.zeros(self.fabric.n + 1, dtype=np.int64)
        for port in range(self.fabric.n):
            offsets[port + 1] = offsets[port] + len(inputs.get(port, ()))
        data = np.zeros(count, dtype=np.uint32)
        last = np.zeros(count, dtype=np.uint8)
        for port, beats in inputs.items():
            start, end = offsets[port], offsets[port + 1]
            data[start:end] = np.asarray(beats, dtype=np.uint32)
            if end > start:
                last[end - 1] = 1
        ports = np.zeros(count, dtype=np.int32)
        out = np.zeros(count, dtype=np.uint32)
        out_last = np.zeros(count, dtype=np.uint8)
        limit = CYCLES_PER_BEAT * count + PIPELINE_SLACK
        got = self._lib.mx_stream(
            self._handle, *_pointers(offsets, data, last), count,
            *_pointers(ports, out, out_last), count, limit,
        )  # fmt: skip
        if got < 0:
            raise FabricStallError(f"the RTL delivered fewer than {count} beats in {limit} cycles")
        return {int(port): out[ports == port].tolist() for port in np.unique(ports)}

    def close(self) -> None:
        """Free the model (later calls fail); calling it twice does nothing."""
        handle, self._handle = self._handle, None
        if handle is not None:
            self._lib.mx_free(handle)

    def __del__(self) -> None:
        self.close()

    def _commit(self, slot: int, route: SlotRoute, beats: list[int]) -> LoadResult:
        """Shift `beats` into `slot`'s wrapper and wait for its commit; a route the rest of the
        routing cannot take with it (a source taken twice) is refused first, as the TLM does."""
        configuration = self.configuration.with_route(slot, route)
        words = np.asarray(beats, dtype=np.uint32)
        code = ctypes.c_int32(-1)
        cycles = self._lib.mx_configure(
            self._handle, slot, words.ctypes.data, len(beats), ctypes.byref(code),
            PIPELINE_SLACK,
        )  # fmt: skip
        if cycles < 0 or code.value != 0:
            said = "no verdict" if cycles < 0 else f"error code {code.value}"
            raise FabricStallError(
                f"slot {slot}: the RTL answered {said} to a frame the decoder accepts"
            )
        self.configuration = configuration
        self.loads += 1
        return LoadResult(slot, route, int(cycles))


def _check_widths(fabric: Fabric, beats: Sequence[int]) -> None:
    limit = 1 << fabric.data_w
    for beat in beats:
        if not 0 <= beat < limit:
            raise DataWidthError(f"expected data below 2**{fabric.data_w}, got {beat}")


def _pointers(*arrays: np.ndarray) -> list[int]:
    return [array.ctypes.data for array in arrays]


def _bind(lib: ctypes.CDLL) -> ctypes.CDLL:
    """`lib`'s functions with their C signatures (`mx_model.cpp`)."""
    lib.mx_new.restype = _POINTER
    lib.mx_new.argtypes = [ctypes.c_int, ctypes.c_int]
    lib.mx_free.restype = None
    lib.mx_free.argtypes = [_POINTER]
    lib.mx_cycles.restype = ctypes.c_uint64
    lib.mx_cycles.argtypes = [_POINTER]
    lib.mx_stream.restype = ctypes.c_int64
    lib.mx_stream.argtypes = [
        _POINTER, _POINTER, _POINTER, _POINTER, ctypes.c_int64,
        _POINTER, _POINTER, _POINTER, ctypes.c_int64, ctypes.c_uint64,
    ]  # fmt: skip
    lib.mx_configure.restype = ctypes.c_int64
    lib.mx_configure.argtypes = [
        _POINTER, ctypes.c_int, _POINTER, ctypes.c_int64, _POINTER, ctypes.c_uint64,
    ]  # fmt: skip
    return lib
