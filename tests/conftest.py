"""Shared test fixtures. Real data is read from ../shared/data beside the checkout (or
$VS_INSPECT_DATA); tests that need it skip with a reason when it is absent."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import numpy  # noqa: F401  (first: pycolmap before numpy breaks zlib, see ENVIRONMENT.md)
import pytest

REPO = Path(__file__).resolve().parents[1]
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("NUMBA_CACHE_DIR", str(REPO / ".cache" / "numba"))
os.environ.setdefault("XDG_CONFIG_HOME", str(REPO / ".cache" / "xdg-config"))
os.environ.setdefault("XDG_DATA_HOME", str(REPO / ".cache" / "xdg-data"))
# whichever test imports ray first: no usage statistics, nodes on 127.0.0.1 (ray reads these at
# import, and tests/test_engine.py's two-node cluster needs the second one)
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
# sync/demo write recordings/<run>.rrd by default; keep the tests' ones out of the checkout, in a
# folder removed when the session ends (each run left one behind in /tmp before)
if "VS_INSPECT_RECORDINGS" not in os.environ:
    _recordings = tempfile.mkdtemp(prefix="vs-inspect-test-recordings-")
    os.environ["VS_INSPECT_RECORDINGS"] = _recordings
    atexit.register(shutil.rmtree, _recordings, ignore_errors=True)


def shared_data_dir() -> Path:
    return Path(os.environ.get("VS_INSPECT_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    d = shared_data_dir()
    if not d.is_dir():
        pytest.skip(f"real test data not found at {d} (set VS_INSPECT_DATA or place shared/ beside the checkout)")
    return d
