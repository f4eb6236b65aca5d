"""Draw the frames figure of docs/visual-servoing.md.

Example:
  python -m visual_servoing.figure docs/img/visual_servoing_frames.png

Three panels of the same view: the clean frame, the frame through the faults of the paper's
experiment (salt-and-pepper noise on top of fog), and that frame after the Dehazer (its numpy
reference, which the guest module matches byte for byte). On each, the SSD match of the square
target (a red cross) against its true position (a green circle): noise throws it off, the
Dehazer brings it back.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from commandline import command_parser, entry_point, run
from commandline.arguments import output_file_ending
from commandline.output import save_figure
from visual_servoing.dehaze import dehaze
from visual_servoing.errors import ServoingError
from visual_servoing.image_faults import FaultSchedule
from visual_servoing.scene import Scene
from visual_servoing.ssd import match_template

YAW = 4.0
TARGET = "square"


def draw(out: Path) -> None:
    """Render the three panels into `out` (PNG)."""
    scene = Scene()
    clean = scene.render(YAW)
    schedule = FaultSchedule(seed=4)
    schedule.add("fog", 0.6)
    schedule.add("salt_pepper", 0.25)
    noisy = schedule.apply(clean, 0.0)
    panels = {"clean": clean, "fog + salt and pepper": noisy, "dehazed": dehaze(noisy).image}
    truth = scene.truth(TARGET, YAW)
    template = scene.template(TARGET)
    figure, axes = plt.subplots(1, len(panels), figsize=(9.0, 3.0))
    for axis, (title, frame) in zip(axes, panels.items(), strict=True):
        match = match_template(frame, template)
        axis.imshow(frame, cmap="gray", vmin=0, vmax=255, interpolation="nearest")
        axis.plot(truth.x, truth.y, "o", mfc="none", mec="lime", ms=14, mew=1.5)
        axis.plot(match.x, match.y, "x", color="red", ms=9, mew=2)
        axis.set_title(f"{title}\nSSD off by {match.x - truth.x:+.1f} px", fontsize=9)
        axis.set_axis_off()
    figure.tight_layout()
    save_figure(figure, out, dpi=80, bbox_inches="tight")
    plt.close(figure)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), ServoingError, argv)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser: one PNG file to write."""
    top = command_parser("python -m visual_servoing.figure", __doc__)
    top.add_argument(
        "out", type=output_file_ending(".png"), metavar="OUT.png", help="the PNG file to write"
    )
    top.set_defaults(func=_draw)
    return top


def _draw(args: argparse.Namespace) -> None:
    draw(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    with entry_point():
        sys.exit(main())
