"""vs_inspect: synchronize unsynchronized videos of one dynamic scene by the epipolar cue."""

# numpy before anything that may load pycolmap: pycolmap first breaks later zlib use (ENVIRONMENT.md).
import numpy as _np  # noqa: F401

__version__ = "0.1.0"
