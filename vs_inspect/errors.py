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


class NoUsableVideos(InputError):
    """Stage 0 could use no video (none opened, or none got a camera).

    stats (types.CueStats) says why for each video and inputs ({name: path}) lists every input,
    so that a run can still report every video as unresolved with its reason.
    """

    def __init__(self, message: str, stats, inputs: dict[str, str] | None = None):
        super().__init__(message)
        self.stats = stats
        self.inputs = dict(inputs or {})
