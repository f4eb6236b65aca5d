"""A plot of a trace: every numeric scalar port over the kernel's time, one panel per PBO.

Vector and frame ports are not drawn (a trace file holds them). matplotlib comes with the
``vision`` extra; it is imported only when a plot is saved.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

from pbort.errors import SetupError
from pbort.ports import PortSpec
from pbort.trace.recorder import Sample


class PlotTrace:
    """Keeps the scalar samples a plot needs, and draws them with `save`."""

    def __init__(self) -> None:
        self._series: dict[str, dict[str, tuple[list[float], list[float]]]] = defaultdict(dict)

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """Keep the sample's numeric scalar values."""
        series = self._series[sample.pbo]
        for name, value in sample.values.items():
            if isinstance(value, (int, float)):
                times, values = series.setdefault(name, ([], []))
                times.append(sample.time)
                values.append(float(value))

    def save(self, path: Path) -> None:
        """Draw one panel per PBO with its ports' lines, as a PNG at `path`."""
        try:
            import matplotlib

            matplotlib.use("Agg")
            from matplotlib import pyplot
        except ImportError:
            raise SetupError(
                "a trace plot needs matplotlib: pip install 'refresh-toolchain[vision]'"
            ) from None
        pbos = sorted(self._series)
        figure, axes = pyplot.subplots(
            max(len(pbos), 1), 1, figsize=(10, 2.6 * max(len(pbos), 1)), sharex=True, squeeze=False
        )
        for axis, pbo in zip(axes[:, 0], pbos, strict=False):
            for port, (times, values) in sorted(self._series[pbo].items()):
                axis.step(times, values, where="post", label=port)
            axis.set_title(pbo, loc="left")
            axis.legend(loc="upper right", fontsize="small")
            axis.grid(alpha=0.3)
        axes[-1, 0].set_xlabel("kernel time (s)")
        figure.tight_layout()
        figure.savefig(path, dpi=100)
        pyplot.close(figure)
