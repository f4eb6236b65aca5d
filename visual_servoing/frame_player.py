"""A native PBO that plays frames: the simplest camera, to feed image modules in a kernel.

Each cycle it writes the next frame of its sequence to output ``image`` (a PBO_FRAME of uint8),
starting over after the last one. Benchmarks and tests use it to drive the Dehazer through the
kernel's ports exactly as a camera module would, without the camera's own cost.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pbort.native import NativeModule, NativePBO, PortIO
from pbort.ports import PortKind, PortSpec
from visual_servoing.errors import TaskSetupError
from visual_servoing.frames import check_frame


def frame_player(frames: Sequence[np.ndarray], name: str = "player") -> NativeModule:
    """A module named `name` that plays `frames` (all of one shape) in a loop on ``image``."""
    if not frames:
        raise TaskSetupError("expected at least one frame to play")
    first = check_frame(frames[0], what="frame 0")
    played = tuple(
        check_frame(frame, first.shape, what=f"frame {index}") for index, frame in enumerate(frames)
    )

    class FramePlayer(NativePBO):
        ports = (PortSpec.output("image", PortKind.FRAME, "u1", first.shape),)

        def init(self, io: PortIO) -> None:
            self.next = 0

        def cycle(self, io: PortIO) -> None:
            io["image"] = played[self.next]
            self.next = (self.next + 1) % len(played)

    FramePlayer.name = name
    return NativeModule(FramePlayer)
