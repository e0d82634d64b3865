"""The sink interface stages report through. Library code never logs to a global recording.

A stage calls these hooks with its typed results; a sink decides what to keep. NullSink keeps
nothing. Hooks have no return value and must not change their arguments.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..types import CueBundle, PairLandscape, SyncResult


class Sink:
    """Base class: every hook is a no-op, so sinks override only what they record."""

    def bundle(self, bundle: CueBundle) -> None:
        """Videos, cameras and tracks that Stage 1 starts from."""

    def pair_landscape(self, landscape: PairLandscape, bundle: CueBundle, energy_fn: Any) -> None:
        """One pair's landscape and decision. energy_fn(offset_s) -> (P,Ts) residuals, for plots."""

    def sync_result(self, result: SyncResult, bundle: CueBundle) -> None:
        """Stage 2's offsets, the pair graph and the IRLS iterations."""

    def stage_event(self, stage: str, message: str, **numbers: Any) -> None:
        """A readable note from any stage (e.g. a camera that could not be registered)."""

    def close(self) -> None:
        """Flush and finish the recording."""


class NullSink(Sink):
    """Records nothing (the default)."""
