"""vs-inspect bench-recording: its cases and options (the recordings themselves take minutes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from vs_inspect.bench.recording import CASES
from vs_inspect.cli import build_parser


def _args(*argv):
    return build_parser().parse_args(["bench-recording", *argv])


def test_cases_default_to_all_and_can_be_named():
    assert CASES == ("demo", "budget", "caliscope")
    assert _args().cases == "all" and _args().out is None
    a = _args("demo", "caliscope", "--out", "/tmp/x", "--data", "/data")
    assert (a.cases, a.out, a.data) == (["demo", "caliscope"], Path("/tmp/x"), Path("/data"))
    with pytest.raises(SystemExit):
        _args("nonsense")
