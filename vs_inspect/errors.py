"""Errors that the CLI turns into one clear message and an exit code (never a traceback)."""

from __future__ import annotations


class VsInspectError(Exception):
    """Base class: bad input that a user can fix. exit_code is what the CLI returns."""

    exit_code = 2


class BundleError(VsInspectError):
    """A cue bundle on disk is malformed. The message names the file and the problem."""

    def __init__(self, path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class InputError(VsInspectError):
    """Bad input other than a bundle: unknown names, unreadable videos, mismatched calibration."""


class BadVideoName(InputError):
    """A video's name (from its file name) cannot be used: the caller must rename the file."""


class NoUsableVideos(InputError):
    """Stage 0 could use no video (none opened, or none got a camera).

    stats (cue_stats.CueStats) says why for each video and inputs ({name: path}) lists every input,
    so that a run can still report every video as unresolved with its reason.
    """

    def __init__(self, message: str, stats, inputs: dict[str, str] | None = None):
        super().__init__(message)
        self.stats = stats
        self.inputs = dict(inputs or {})


def check_fields(obj, *, positive=(), nonnegative=(), fraction=(), at_least=None, at_most=None) -> None:
    """Validate a config dataclass's numeric fields; ValueError naming the option (its "flag"
    metadata, else the field) on the first bad one. Every float field must be finite (None allowed
    where the field is optional); `positive` > 0, `nonnegative` >= 0, `fraction` in [0, 1],
    at_least / at_most: {field: bound}. Bools are not numbers here."""
    import dataclasses
    import math

    def name(f) -> str:
        return f.metadata.get("flag") or f.name

    fields = {f.name: f for f in dataclasses.fields(obj)}
    for f in fields.values():
        v = getattr(obj, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"{name(f)} must be a finite number, got {v!r}")
        if f.name in positive and not v > 0:
            raise ValueError(f"{name(f)} must be positive, got {v!r}")
        if f.name in nonnegative and not v >= 0:
            raise ValueError(f"{name(f)} must be >= 0, got {v!r}")
        if f.name in fraction and not 0 <= v <= 1:
            raise ValueError(f"{name(f)} must be in [0, 1], got {v!r}")
        if at_least and f.name in at_least and not v >= at_least[f.name]:
            raise ValueError(f"{name(f)} must be >= {at_least[f.name]}, got {v!r}")
        if at_most and f.name in at_most and not v <= at_most[f.name]:
            raise ValueError(f"{name(f)} must be <= {at_most[f.name]}, got {v!r}")


class OutputBusy(VsInspectError):
    """Another run is writing the same output (its lock is held); the message names that run."""
