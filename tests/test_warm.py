"""Every compiled kernel of the package is cached by numba (so `python -m vs_inspect.warm`, which
`make setup` runs, takes its compilation out of the first run), and the warm-up knows them all."""

from __future__ import annotations

import importlib
import pkgutil

import numba

import vs_inspect
from vs_inspect import warm


def _dispatchers():
    """(module.name, dispatcher) of every numba function defined in the package."""
    for info in pkgutil.walk_packages(vs_inspect.__path__, "vs_inspect."):
        if info.name.split(".")[1] in ("bench", "commands") or info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for name, f in vars(module).items():
            if isinstance(f, numba.core.registry.CPUDispatcher) and f.__module__ == module.__name__:
                yield f"{module.__name__}.{name}", f


def test_every_kernel_is_cached_and_warmed():
    kernels = dict(_dispatchers())
    assert len(kernels) >= 6
    outer = {k: f for k, f in kernels.items() if f.targetoptions.get("inline", "never") != "always"}
    uncached = [k for k, f in outer.items() if f._cache.__class__.__name__ == "NullCache"]
    assert uncached == []  # inlined helpers are compiled inside their callers' cached code
    warmed = set(warm.cached_kernels())
    assert {k.split(".", 1)[-1] for k in outer} <= warmed, \
        (sorted(outer), sorted(warmed))
