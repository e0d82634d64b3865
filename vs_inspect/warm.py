"""Compile the package's numba kernels into numba's cache before the first run needs them.

    python -m vs_inspect.warm          (`make setup` runs it)

A tiny rendered scene (3 cameras, one hand-held, 2 s, 240x180) goes through the whole pipeline:
Stage 1 + 2 on its true cue bundle read from disk, and its videos through Stage 0 + 1 + 2 with
their calibration, as `vs-inspect demo` sends its own scene; guided matching, which only
estimated cameras use, runs on two made-up images. So every cached kernel (the energy landscapes
of static and moving cameras, the epipolar vote, nearest-neighbour and guided matching) is
compiled for the argument types real runs give it, and a first run loads them from the cache
instead of compiling them. numba keeps its cache in NUMBA_CACHE_DIR when that is set, else beside
the package's sources; a run uses the one its environment names.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np  # noqa: F401  (before anything that may import pycolmap)

SCENE = dict(cameras=3, moving=1, seconds=2.0, width=240, height=180, fps=None, variable_rate=1,
             exposure=True, points_per_object=30, seed=0)


# the modules whose numba kernels are cached, under the package
KERNEL_MODULES = ("sync.kernels", "sync.people_search", "cues.pairing.vote_kernels", "cues.features.guided",
                  "cues.features.nearest_neighbours")


def _kernels() -> dict[str, object]:
    """{"module.path.name" (under the package): dispatcher} of the cached kernels."""
    import importlib

    import numba
    out = {}
    for path in KERNEL_MODULES:
        module = importlib.import_module(f"vs_inspect.{path}")
        for name, f in vars(module).items():
            if isinstance(f, numba.core.registry.CPUDispatcher) and f._cache.__class__.__name__ != "NullCache":
                out[f"{path}.{name}"] = f
    return out


def cached_kernels() -> dict[str, int]:
    """{kernel ("module.path.name" under the package): specializations compiled or loaded in this
    process} of the cached kernels."""
    return {k: len(f.signatures) for k, f in _kernels().items()}


def _has_cache_index(kernel: str) -> bool:
    """Whether numba's cache holds an index for `kernel` (as cached_kernels names it)."""
    import os
    return os.path.exists(_kernels()[kernel]._cache._cache_file._index_path)


def warm(workdir: str | Path | None = None) -> dict[str, float]:
    """Run the tiny scene through the pipeline (see above); {step: seconds}."""
    from .pipeline import run
    from .synth.videos import render_scene
    from .synth.world import SceneConfig, make_scene

    times: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="vs-inspect-warm-", dir=workdir) as tmp:
        scene_dir = Path(tmp) / "scene"
        t = time.perf_counter()
        render_scene(make_scene(SceneConfig(**SCENE)), scene_dir, progress=False)
        times["render_s"] = time.perf_counter() - t
        t = time.perf_counter()
        run(scene_dir / "bundle", progress=False)
        times["true_cues_s"] = time.perf_counter() - t
        t = time.perf_counter()
        run(sorted(scene_dir.glob("cam*.mp4")), calibration=scene_dir / "calibration.json",
            bundle_out=Path(tmp) / "cues", progress=False)
        times["videos_s"] = time.perf_counter() - t
    # guided matching refines an estimated camera model's matches (pycolmap): its arguments are
    # normalised to one set of types, so two made-up images compile it
    from .cues.features.guided import guided_matches
    t = time.perf_counter()
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 200, (16, 2)).astype(np.float32)
    desc = rng.integers(0, 256, (16, 128), dtype=np.uint8)
    guided_matches(xy, desc, xy + 1.0, desc, np.eye(3), True)
    times["guided_s"] = time.perf_counter() - t
    # the people cue's pairing score (its arguments are normalised to float64/int64 arrays):
    # made-up landmarks of two people in three frames compile it without running pose detection
    from .geometry.skeleton import MIRROR
    from .sync.people_search import _score
    t = time.perf_counter()
    landmarks = rng.uniform(0, 200, (2, 3, len(MIRROR), 2))
    _score(np.eye(3)[[1, 0, 2]], landmarks, landmarks + 1.0, MIRROR, np.full((2, 2), 4.0))
    times["people_s"] = time.perf_counter() - t
    return times


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m vs_inspect.warm", description=__doc__.split("\n\n")[0])
    p.add_argument("--quiet", action="store_true", help="print nothing")
    args = p.parse_args(argv)
    import logging
    logging.basicConfig(level=logging.ERROR)
    t = time.perf_counter()
    times = warm()
    kernels = cached_kernels()
    if not args.quiet:
        import numba
        where = numba.config.CACHE_DIR or "beside the package's sources"
        print(f"numba kernels compiled into the cache ({where}) in {time.perf_counter() - t:.0f} s: "
              + ", ".join(f"{k} ({n})" for k, n in sorted(kernels.items())))
        print("steps: " + ", ".join(f"{k} {v:.1f}" for k, v in times.items()))
    # a kernel called only from other kernels is loaded inside its caller's cached code, so it
    # shows no signature of its own when the cache was already warm: its cache index says it is there
    missing = [k for k, n in kernels.items() if n == 0 and not _has_cache_index(k)]
    if missing:
        print(f"not compiled: {', '.join(missing)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
