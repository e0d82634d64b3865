"""Sinks that stages report to: NullSink (nothing) and, with rerun, RerunSink (.rrd file).

RerunSink lives in record.rerun_sink (imported on demand: it pulls in rerun), its viewer layout in
record.blueprint; io.recording_paths names the recording's entities and io.recording reads a
recording back.
"""

from ..analysis.record_options import RecordOptions
from .sink import NullSink, Sink

__all__ = ["NullSink", "RecordOptions", "Sink"]
