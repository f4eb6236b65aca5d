"""One recording: trace files and a plot for a kernel, opened together and closed together."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, closing, contextmanager
from pathlib import Path

from pbort.errors import TraceWriteError
from pbort.kernel import Kernel
from pbort.trace.files import open_trace
from pbort.trace.plot import PlotTrace
from pbort.trace.recorder import Recorder, TraceWriter


@contextmanager
def recording(
    kernel: Kernel,
    traces: Sequence[Path],
    plot: Path | None = None,
    plot_ports: Sequence[str] = (),
    live: Sequence[TraceWriter] = (),
    on_failure: Callable[[TraceWriteError], None] | None = None,
) -> Iterator[None]:
    """Record every job of `kernel` into each of `traces` (by suffix) while the block runs, then
    close them, whatever ended the block, and draw `plot` (of `plot_ports`, ``PBO.port``; none:
    every input and output). Samples go to the `live` writers too (a `pbort.trace.live`
    view, which its caller closes). A trace the disk refuses ends the block with
    TraceWriteError, or with `on_failure` stops alone (`Recorder`). Nothing is opened when
    there is nothing to record."""
    if not traces and plot is None and not live:
        yield
        return
    with ExitStack() as files:
        writers: list[TraceWriter] = [
            *live,
            *(files.enter_context(closing(open_trace(path))) for path in traces),
        ]
        drawing = PlotTrace(plot_ports) if plot is not None else None
        if drawing is not None:
            writers.append(drawing)
        recorder = Recorder(kernel, writers, on_failure)
        try:
            yield
        finally:
            recorder.stop()
        if drawing is not None and plot is not None:
            drawing.save(plot)
