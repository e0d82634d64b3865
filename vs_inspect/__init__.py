"""vs_inspect: synchronize unsynchronized videos of one dynamic scene by the epipolar cue."""

# No imports here: the vs-inspect command installs its signal handlers (vs_inspect._entry) before
# anything heavy loads. numpy must load before pycolmap (ENVIRONMENT.md): every pycolmap import
# goes through signals.import_pycolmap(), which imports numpy first.

__version__ = "0.1.0"
