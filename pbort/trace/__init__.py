"""Traces of a kernel's ports over its clock: a recorder that samples each PBO's ports after its
jobs, and writers for CSV (spreadsheets, pandas) and MCAP (Foxglove, PlotJuggler).

    with recording(kernel, [Path("run.csv"), Path("run.mcap")], plot=Path("run.png")):
        kernel.run(until=1.0)
"""

from pbort.trace.files import TRACE_SUFFIXES, TraceFormatError, check_trace_name, open_trace
from pbort.trace.recorder import Recorder, Sample
from pbort.trace.session import recording

__all__ = [
    "TRACE_SUFFIXES",
    "Recorder",
    "Sample",
    "TraceFormatError",
    "check_trace_name",
    "open_trace",
    "recording",
]
