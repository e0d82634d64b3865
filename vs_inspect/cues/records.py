"""What a Stage 0 step says besides its result: notes in words for the run's log and recording."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Note:
    """One readable note of a step (a camera that could not be registered, a pair's geometric
    track pairs and why), with the numbers behind it; the Stage 0 controller reports it."""

    stage: str  # "cues" | "cameras"
    message: str
    numbers: dict[str, float | str] = field(default_factory=dict)  # as Sink.stage_event takes them


def say(notes: list[Note], message: str, **numbers: float | str) -> None:
    """Append a note of the cue-finding steps."""
    notes.append(Note("cues", message, numbers))


def say_cameras(notes: list[Note], message: str, **numbers: float | str) -> None:
    """Append a note of the camera steps."""
    notes.append(Note("cameras", message, numbers))
