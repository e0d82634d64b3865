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
