"""Where per-item work runs: in this process (local) or as Ray tasks (ray).

Stage 0 maps its per-video step and Stage 1 its per-pair step over an Engine:

    with open_engine(EngineConfig("ray")) as engine:
        for out in engine.map(pair_task, pairs, shared=(bundle, cfg), desc="pair landscapes"):
            ...

map yields one result per item in the order of the items, whichever engine runs them, so
everything the driver builds from them (offsets, the recording, result.json) is the same. The
item function is fn(shared, item) -> result, a module-level function (Ray pickles it by name);
`shared` is sent once (a Ray object reference that every task reads from the object store), not
with every item. A Python exception in a task is raised on the driver as it would be locally; a
task that dies with its worker or node (a crash, out of memory) yields TaskFailed with the reason
instead, so the caller can leave that item out and finish the others.

A bottom-layer module (like types.py) so that cues/ and pipeline/ can both map over it. Ray is
imported only when a RayEngine is opened (the `distributed` extra).
"""

from __future__ import annotations

import functools
import logging
import multiprocessing
import os
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tqdm import tqdm

from . import signals
from .errors import InputError, check_fields

log = logging.getLogger(__name__)

ENGINES = ("local", "ray")


@dataclass(frozen=True)
class EngineConfig:
    kind: str = field(default="local", metadata={"flag": "--engine", "choices": ENGINES})
    """Where Stage 0 (per video) and Stage 1 (per pair) run: local (in this process) or ray (Ray tasks, on this machine unless --ray-address names a cluster); the offsets are the same."""
    ray_address: str | None = field(default=None, metadata={"flag": "--ray-address", "metavar": "ADDR"})
    """Address of a running Ray cluster to join (HOST:6379 of its head, or auto); None = start an embedded Ray on this machine."""
    ray_cpus: int | None = field(default=None, metadata={"flag": "--ray-cpus", "metavar": "N"})
    """CPUs of the embedded Ray (without --ray-address); None = all cores of this machine."""

    def __post_init__(self) -> None:
        if self.kind not in ENGINES:
            raise ValueError(f"unknown engine {self.kind!r}; choose one of {ENGINES}")
        check_fields(self, positive=("ray_cpus",))


@dataclass(frozen=True)
class TaskFailed:
    """An item whose task did not return: its worker or node died (the reason says how)."""

    reason: str


class Engine:
    """Maps fn(shared, item) over items; results in the order of the items."""

    name = "base"

    def map(self, fn: Callable[[Any, Any], Any], items: Iterable[Any], *, shared: Any = None,
            desc: str = "", unit: str = "item", progress: bool = True,
            processes: bool = False, threads: bool = False) -> Iterator[Any]:
        """processes: the items are single-threaded CPU work (no numba threads inside), so the
        local engine may fork one process per core for them. threads: the items release the GIL
        for most of their work (OpenCV, numpy) and share no state, so the local engine runs two at
        a time on threads (not more: each holds its own data, a video's frames). Ray runs every
        item as a task."""
        raise NotImplementedError

    def close(self) -> None:
        """Release what the engine started (nothing for local)."""

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class LocalEngine(Engine):
    """In this process, one item after another, exceptions as they are; items marked
    processes=True in forked processes, one per core, and threads=True on two threads (results
    and exceptions the same)."""

    name = "local"

    def map(self, fn, items, *, shared=None, desc="", unit="item", progress=True, processes=False,
            threads=False):
        items = list(items)
        workers = min(len(items), os.cpu_count() or 1) if processes or threads else 1
        if threads and not processes and workers > 1:
            pool = ThreadPoolExecutor(min(workers, 2), thread_name_prefix="engine")
            try:
                for out in tqdm(pool.map(functools.partial(_checked, fn, shared), items), total=len(items),
                                desc=desc, unit=unit, disable=not progress, leave=False):
                    signals.checkpoint()
                    yield out
            finally:  # left early (an error, Ctrl-C): the items not started are not run
                pool.shutdown(wait=True, cancel_futures=True)
            return
        if workers <= 1:
            for item in tqdm(items, desc=desc, unit=unit, disable=not progress, leave=False):
                signals.checkpoint()
                out = fn(shared, item)
                signals.checkpoint()
                yield out
            return
        global _FORKED
        _FORKED = (fn, shared)  # inherited by the forked workers: the bundle is never pickled
        try:
            before = set(multiprocessing.active_children())
            pool = multiprocessing.get_context("fork").Pool(workers, initializer=_forked_init)
            mine = [p for p in multiprocessing.active_children() if p not in before]
            try:
                for out in tqdm(pool.imap(_forked_call, items), total=len(items), desc=desc, unit=unit,
                                disable=not progress, leave=False):
                    signals.checkpoint()
                    yield out
            finally:
                stop_pool(pool, mine)
        finally:
            _FORKED = None


_FORKED: tuple[Callable[[Any, Any], Any], Any] | None = None  # (fn, shared) of the running map


def stop_pool(pool, workers: list, grace_s: float = 10.0) -> None:
    """pool.terminate(), which sends each worker SIGTERM and then waits for them without a limit:
    workers still alive grace_s later are killed (SIGKILL) so that it returns. A fork-pool worker
    once missed its SIGTERM in CI and the test suite waited for it until its timeout (the worker
    idle in its task loop, the driver in terminate's join)."""
    stopper = threading.Thread(target=pool.terminate, name="pool-terminate", daemon=True)
    stopper.start()
    stopper.join(grace_s)
    if stopper.is_alive():
        left = [p for p in workers if p.exitcode is None]
        log.warning("%d forked worker(s) still alive %.0f s after SIGTERM: killed", len(left), grace_s)
        for p in left:
            p.kill()
        stopper.join()


def _forked_init() -> None:
    # the pool ends its workers with SIGTERM (its default action); Ctrl-C reaches the whole
    # process group, and the parent stops the pool at its next safe point
    signals.in_forked_worker()


def _checked(fn, shared, item):
    signals.checkpoint()  # a stopped run starts no more items
    return fn(shared, item)


def _forked_call(item):
    fn, shared = _FORKED
    return fn(shared, item)


def _call(fn, shared, item):
    """The body of every Ray task (module level so that workers import it by name)."""
    import numba
    # a task has one CPU: compiled kernels use one thread (their results do not depend on it:
    # the work is split by the thread count the driver fixed in the task's settings)
    numba.set_num_threads(1)
    return fn(shared, item)


class RayEngine(Engine):
    """Ray tasks on an embedded Ray or a cluster (address). Closing shuts down only a Ray that
    this engine started or joined, not one the caller had initialized."""

    name = "ray"

    def __init__(self, address: str | None = None, num_cpus: int | None = None):
        # no usage statistics and no dashboard: nothing leaves the machine
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        if not address:
            # an embedded Ray listens on the loopback address only (Ray otherwise binds to the
            # machine's network address, which a single machine does not need); read when ray
            # is first imported
            os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        try:
            import ray
        except ImportError:
            raise InputError("--engine ray needs the ray package: pip install 'vs_inspect[distributed]'") from None
        self._ray = ray
        self._owned = not ray.is_initialized()
        if self._owned:
            # the workers import the same vs_inspect as this driver when its folder is reachable
            # from them (the embedded Ray, or a cluster on shared storage)
            here = str(Path(__file__).resolve().parents[1])
            path = os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH", "")) if p)
            kw: dict[str, Any] = {"log_to_driver": False, "configure_logging": False,
                                  "runtime_env": {"env_vars": {"PYTHONPATH": path}}}
            try:
                if address:
                    ray.init(address=address, **kw)
                else:
                    # "local": always a new Ray of its own, never one found running on the machine
                    ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1,
                             include_dashboard=False, **kw)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                where = f"the Ray cluster at {address}" if address else "an embedded Ray"
                raise InputError(f"--engine ray: could not start or join {where}: {exc}") from None
        self._task = ray.remote(num_cpus=1, max_retries=1)(_call)

    @property
    def cpus(self) -> int:
        """CPUs of the cluster (all nodes)."""
        return int(self._ray.cluster_resources().get("CPU", 1))

    def map(self, fn, items, *, shared=None, desc="", unit="item", progress=True, processes=False,
            threads=False):
        ray = self._ray
        items = list(items)
        ref = ray.put(shared)  # once: every task reads it from the object store
        refs = [self._task.remote(fn, ref, it) for it in items]
        lost = (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError,
                ray.exceptions.ObjectLostError, ray.exceptions.OutOfMemoryError,
                ray.exceptions.TaskCancelledError, ray.exceptions.RaySystemError)
        got = 0
        try:
            for r in tqdm(refs, desc=desc, unit=unit, disable=not progress, leave=False):
                try:
                    out = ray.get(r)
                except ray.exceptions.RayTaskError as exc:
                    cause = getattr(exc, "cause", None)
                    if isinstance(cause, BaseException):
                        raise cause from None
                    raise
                except lost as exc:
                    first = (str(exc).strip().splitlines() or [""])[0]
                    log.warning("a Ray task was lost: %s: %s", type(exc).__name__, first)
                    out = TaskFailed(f"its Ray task was lost ({type(exc).__name__}: {first})")
                got += 1
                signals.checkpoint()
                yield out
        finally:
            rest = refs[got:]
            if rest:  # a stopped run leaves no task running (finished ones are left alone)
                _, pending = ray.wait(rest, num_returns=len(rest), timeout=0)
                for r in pending:
                    ray.cancel(r)

    def close(self) -> None:
        if self._owned and self._ray.is_initialized():
            self._ray.shutdown()
            self._owned = False


def open_engine(cfg: EngineConfig = EngineConfig()) -> Engine:
    """The engine cfg names (a RayEngine starts or joins Ray here); close it (or use `with`)."""
    if cfg.kind == "ray":
        return RayEngine(cfg.ray_address, cfg.ray_cpus)
    return LocalEngine()
