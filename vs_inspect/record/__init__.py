"""Sinks that stages report to: NullSink (nothing) and, with rerun, RerunSink (.rrd file)."""

from .sink import NullSink, Sink

__all__ = ["NullSink", "Sink"]
