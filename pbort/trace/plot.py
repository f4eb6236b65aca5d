"""A plot of a trace: numeric scalar ports over the kernel's time, one panel per PBO.

By default every input and output is drawn, not the constants: a constant does not move, and
one of 131072 (gain.k, Q16.16) would flatten the signals on its panel's axis. Naming ports
(``PBO.port``) draws those only, constants too. Vector and frame ports are not drawn (a trace
file holds them). matplotlib comes with the ``vision`` extra; it is imported only when a plot is
saved.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

from commandline.output import save_figure
from pbort.errors import SetupError, TraceWriteError
from pbort.ports import Direction, PortSpec
from pbort.trace.recorder import Sample


class PlotTrace:
    """Keeps the scalar samples a plot needs, and draws them with `save`; `chosen` names the
    ports to draw (``PBO.port``; none: every input and output)."""

    def __init__(self, chosen: Sequence[str] = ()) -> None:
        self._series: dict[str, dict[str, tuple[list[float], list[float]]]] = defaultdict(dict)
        self._chosen = frozenset(chosen)

    def wants(self, pbo: str) -> bool:
        """Every sample."""
        return True

    def write(self, sample: Sample, ports: Sequence[PortSpec]) -> None:
        """Keep the sample's numeric scalar values of the ports drawn."""
        series = self._series[sample.pbo]
        signals = {p.name for p in ports if p.direction in (Direction.IN, Direction.OUT)}
        for name, value in sample.values.items():
            drawn = f"{sample.pbo}.{name}" in self._chosen if self._chosen else name in signals
            if drawn and isinstance(value, (int, float)):
                times, values = series.setdefault(name, ([], []))
                times.append(sample.time)
                values.append(float(value))

    def save(self, path: Path) -> None:
        """Draw one panel per PBO with its ports' lines, as a PNG at `path`, whole or not at all
        (TraceWriteError when the disk refuses it)."""
        try:
            import matplotlib

            matplotlib.use("Agg")
            from matplotlib import pyplot
        except ImportError:
            raise SetupError(
                "a trace plot needs matplotlib: pip install 'refresh-toolchain[vision]'"
            ) from None
        pbos = sorted(pbo for pbo, series in self._series.items() if series)
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
        try:
            save_figure(figure, path, dpi=100)
        except OSError as error:
            raise TraceWriteError(path, error) from None
        finally:
            pyplot.close(figure)
