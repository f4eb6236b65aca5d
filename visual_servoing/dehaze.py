"""The Dehazer's algorithm in numpy: the reference the guest module must match byte for byte.

guest/dehazer.c runs the same two steps on the emulated CPU; the tests feed both the same frames
and require identical output and identical performance figures. The numpy version is written
differently on purpose (a sort of the nine neighbours, a partition for the percentiles), so that
agreeing bytes say the C is right, not merely that two copies share a bug.

1. A 3x3 median with replicated edges (as OpenCV's ``medianBlur``): removes salt-and-pepper
   noise, reduces Gaussian noise.
2. A contrast stretch: ``low`` and ``high`` are the levels of rank ``clip_rank`` and
   ``pixels - 1 - clip_rank`` of the median image (its 1st and 99th percentiles); levels map
   linearly from [low, high] onto [0, 255], rounded, clipped at both ends. This undoes fog, which
   pulls every level towards a grey. A frame whose spread is below `MIN_SPREAD` (blank, black) is
   left as it is: stretching it would only amplify noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visual_servoing.frames import check_frame

WHITE = 255
LEVELS = 256
CLIP_PERMILLE = 10  # 1 % of the pixels clip at each end of the stretch
MIN_SPREAD = 16  # a median image whose high - low is smaller is not stretched


@dataclass(frozen=True)
class Dehazed:
    """A dehazed frame and what the Dehazer's evaluator reports about it.

    `low` and `high` are the percentiles of the median image (its contrast before the stretch),
    `output_low` and `output_high` where the stretch put them, and `noise_sum` the sum over all
    pixels of |raw - median|, the noise the median removed.
    """

    image: np.ndarray
    low: int
    high: int
    output_low: int
    output_high: int
    noise_sum: int

    @property
    def input_contrast(self) -> int:
        """high - low in grey levels: small under fog."""
        return self.high - self.low

    @property
    def output_contrast(self) -> int:
        """The spread the stretch delivered: 255 once restored, less on a frame too flat."""
        return self.output_high - self.output_low

    @property
    def noise_removed(self) -> float:
        """Mean |raw - median| per pixel in grey levels, in thousandths rounded down as the
        guest reports it (the guest has no floating point)."""
        return (self.noise_sum * 1000 // self.image.size) / 1000


def median3x3(frame: np.ndarray) -> np.ndarray:
    """The 3x3 median of every pixel, the frame's edges replicated outwards."""
    frame = check_frame(frame)
    rows, columns = frame.shape
    padded = np.pad(frame, 1, mode="edge")
    neighbours = np.stack(
        [padded[dy : dy + rows, dx : dx + columns] for dy in range(3) for dx in range(3)]
    )
    return np.sort(neighbours, axis=0)[4]


def clip_rank(pixels: int) -> int:
    """The rank (from 0) of the low percentile among `pixels` levels: 192 of 19200."""
    return pixels * CLIP_PERMILLE // 1000


def percentiles(image: np.ndarray) -> tuple[int, int]:
    """The levels of rank `clip_rank` and its mirror from the top, as ints."""
    flat = image.ravel()
    low_rank = clip_rank(flat.size)
    high_rank = flat.size - 1 - low_rank
    ranked = np.partition(flat, (low_rank, high_rank))
    return int(ranked[low_rank]), int(ranked[high_rank])


def stretch_table(low: int, high: int) -> np.ndarray:
    """The 256-entry lookup table of the stretch of [low, high] onto [0, 255] (identity when the
    spread is below MIN_SPREAD), in integers exactly as the guest computes it."""
    levels = np.arange(LEVELS, dtype=np.int64)
    spread = high - low
    if spread < MIN_SPREAD:
        return levels.astype(np.uint8)
    stretched = ((levels - low) * WHITE + spread // 2) // spread
    return np.where(levels <= low, 0, np.where(levels >= high, WHITE, stretched)).astype(np.uint8)


def dehaze(frame: np.ndarray) -> Dehazed:
    """Median, then stretch: the Dehazer's cycle and its evaluator's figures."""
    frame = check_frame(frame)
    median = median3x3(frame)
    low, high = percentiles(median)
    table = stretch_table(low, high)
    noise = np.abs(frame.astype(np.int32) - median.astype(np.int32)).sum()
    return Dehazed(
        image=table[median],
        low=low,
        high=high,
        output_low=int(table[low]),
        output_high=int(table[high]),
        noise_sum=int(noise),
    )
