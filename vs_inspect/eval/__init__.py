"""Metrics of the paper: pairwise A@100 / A@500 and per-video δ_mean / δ_med."""

from .metrics import SyncMetrics, evaluate_offsets, offset_errors_ms

__all__ = ["SyncMetrics", "evaluate_offsets", "offset_errors_ms"]
