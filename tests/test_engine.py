"""The engines: identical offsets in-process and on a real two-node Ray cluster on this machine,
and a video whose task fails (a corrupt stream) is null with its reason while the rest finish."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.bench.scale import RANGE_S, rig_config
from vs_inspect.engine import EngineConfig, LocalEngine, TaskFailed, open_engine
from vs_inspect.errors import InputError
from vs_inspect.pipeline import RunConfig, run
from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.record.sink import Sink
from vs_inspect.sync.config import LandscapeConfig, PairSelection, SyncConfig
from vs_inspect.synth.cues import make_cue_scene

REPO = Path(__file__).resolve().parents[1]


def _double(shared, x):
    return shared * x


def _fails(shared, x):
    raise InputError(f"item {x} is bad")


def test_local_engine_keeps_order_and_raises_as_is():
    with open_engine(EngineConfig()) as eng:
        assert isinstance(eng, LocalEngine)
        assert list(eng.map(_double, [3, 1, 2], shared=10, progress=False)) == [30, 10, 20]
        with pytest.raises(InputError, match="item 1 is bad"):
            list(eng.map(_fails, [1], progress=False))


def _pid_and_double(shared, x):
    return os.getpid(), shared * x


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: the local engine does not fork")
def test_local_engine_forks_marked_items_in_order_and_raises_as_is():
    """processes=True: forked workers (not this process), results in the items' order, the shared
    value inherited, an exception raised as it is."""
    eng = LocalEngine()
    out = list(eng.map(_pid_and_double, list(range(8)), shared=np.arange(3), progress=False, processes=True))
    assert [list(v) for _, v in out] == [list(np.arange(3) * x) for x in range(8)]
    assert os.getpid() not in {pid for pid, _ in out}
    with pytest.raises(InputError, match="item 2 is bad"):
        list(eng.map(_fails, [2, 3], progress=False, processes=True))


def _thread_and_double(shared, x):
    import threading
    import time

    time.sleep(0.05 * (3 - x % 3))  # later items finish first
    return threading.current_thread().name, shared * x


def _record_start(started, x):
    import time

    started.append(x)
    time.sleep(0.1)
    return x


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: the local engine runs items one by one")
def test_local_engine_runs_items_marked_threads_two_at_a_time_in_order():
    """threads=True: two worker threads of this process, results in the items' order whatever
    finishes first, an exception raised as it is."""
    eng = LocalEngine()
    out = list(eng.map(_thread_and_double, list(range(6)), shared=10, progress=False, threads=True))
    assert [v for _, v in out] == [10 * x for x in range(6)]
    names = {name for name, _ in out}
    assert len(names) == 2 and all(n.startswith("engine") for n in names), names
    with pytest.raises(InputError, match="item 2 is bad"):
        list(eng.map(_fails, [2, 3], progress=False, threads=True))
    # a caller that stops early: the items not yet started are not run
    started = []
    items = eng.map(_record_start, list(range(20)), shared=started, progress=False, threads=True)
    next(items)
    items.close()
    assert 2 <= len(started) < 20, started


def test_engine_config_rejects_unknown_engine():
    with pytest.raises(ValueError, match="unknown engine 'spark'"):
        EngineConfig("spark")


@pytest.fixture(scope="module")
def ray_cluster():
    """A real Ray cluster on 127.0.0.1: a head node and a second worker node, one CPU each."""
    keys = ("RAY_USAGE_STATS_ENABLED", "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "PYTHONPATH")
    saved = {k: os.environ.get(k) for k in keys}
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"  # no network
    # every node on 127.0.0.1 (Ray otherwise resolves it to the machine's network address);
    # ray reads this when it is first imported
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'vs_inspect[distributed]')")
    from ray._private import ray_constants
    from ray.cluster_utils import Cluster

    if ray_constants.ENABLE_RAY_CLUSTER:
        pytest.skip("ray was imported before this test could keep its nodes on 127.0.0.1")
    # the nodes' workers import this checkout's vs_inspect, like the driver
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), saved["PYTHONPATH"]) if p)
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False,
                                                            "node_ip_address": "127.0.0.1"})
    cluster.add_node(num_cpus=1, node_ip_address="127.0.0.1")
    cluster.wait_for_nodes()
    try:
        yield cluster.address
    finally:
        if ray.is_initialized():
            ray.shutdown()
        cluster.shutdown()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _moving_disk_video(path, shift_frames: int) -> None:
    """A textured static background and a textured disk moving across it, 10 fps, 3 s."""
    from vs_inspect.io.video import VideoWriter
    rng = np.random.default_rng(0)
    bg = np.repeat((rng.random((240, 320)) * 120).astype(np.uint8)[:, :, None], 3, axis=2)
    skin = np.repeat((130 + rng.random((240, 320)) * 125).astype(np.uint8)[:, :, None], 3, axis=2)
    yy, xx = np.mgrid[:240, :320]
    with VideoWriter(path, 320, 240, 10.0) as w:
        for k in range(30):
            t = k + shift_frames
            dx, dy = 60 + 6 * t, 100 + 2 * t
            img = bg.copy()
            disk = (xx - dx) ** 2 + (yy - dy) ** 2 < 35 ** 2
            # the disk's texture moves with it (trackable points inside the moving region)
            img[disk] = skin[(yy[disk] - dy) % 240, (xx[disk] - dx) % 320]
            w.write(img)


def _corrupt_tail(src: Path, dst: Path) -> None:
    """dst = src with its last 8 packets zeroed: it opens (the probe decodes only the first
    frame), then fails when the task decodes it."""
    import av
    data = bytearray(src.read_bytes())
    with av.open(str(src)) as c:
        packets = [(p.pos, p.size) for p in c.demux(c.streams.video[0]) if p.size]
    for pos, size in packets[-8:]:
        data[pos:pos + size] = bytes(size)
    dst.write_bytes(bytes(data))


def test_twelve_cameras_same_offsets_local_and_ray_cluster(ray_cluster):
    import ray
    bundle = make_cue_scene(rig_config(12)).bundle
    sync = SyncConfig(landscape=LandscapeConfig(range_s=RANGE_S), pairs=PairSelection.parse("knn:3"))
    local = run(bundle, RunConfig(sync=sync), progress=False)
    cfg = RunConfig(sync=sync, engine=EngineConfig("ray", ray_address=ray_cluster))
    with open_engine(cfg.engine) as eng:
        assert len([n for n in ray.nodes() if n["Alive"]]) == 2 and eng.cpus == 2
        distributed = run(bundle, cfg, progress=False, engine=eng)
    assert not ray.is_initialized()  # the engine that joined the cluster also left it
    assert sum(v is not None for v in local.offsets_s.values()) >= 10
    assert distributed.offsets_s == local.offsets_s  # bit for bit
    assert distributed.uncertainty_s == local.uncertainty_s
    assert [(p.a, p.b, p.decision.accepted) for p in distributed.pairs] == \
           [(p.a, p.b, p.decision.accepted) for p in local.pairs]
    for d, l in zip(distributed.pairs, local.pairs):
        np.testing.assert_array_equal(d.energy, l.energy)


class _Calls(Sink):
    """A recording sink that notes every hook call (with a digest of the images it gets)."""

    def __init__(self):
        self.options = RecordOptions()
        self.calls: list[tuple] = []

    def video(self, info, path):
        self.calls.append(("video", info.name))

    def video_frame(self, name, frame_index, image_bgr):
        self.calls.append(("frame", name, frame_index, hashlib.sha1(image_bgr.tobytes()).hexdigest()))

    def dynamic_mask(self, name, frame_index, instances):
        self.calls.append(("mask", name, frame_index, hashlib.sha1(instances.tobytes()).hexdigest()))

    def cameras(self, cameras, points_world, colors):
        self.calls.append(("cameras", tuple(cameras)))

    def pair_landscape(self, landscape, view=None):
        self.calls.append(("pair", landscape.a, landscape.b, landscape.energy.tobytes(), view is not None))

    def sync_result(self, result, view=None):
        self.calls.append(("sync", tuple(result.offsets_s.items()), view is not None))

    def stage_event(self, stage, message, **numbers):
        self.calls.append(("event", stage, message))


def test_corrupt_video_task_is_null_with_its_reason_and_the_rest_finish(ray_cluster, tmp_path):
    """...and a recording sink sees the same calls, in the same order, under both engines. Four
    readable videos: three give one triangle, which several choices of this toy's vote peaks
    close within its 3-frame (0.3 s) tolerance, and Stage 0 refuses a single triangle's choice
    (consistent_peaks: one triangle); four give four triangles."""
    import json
    videos = [tmp_path / f"v{i}.mp4" for i in range(4)]
    for i, v in enumerate(videos):
        _moving_disk_video(v, 2 * i)
    good = tmp_path / "full.mp4"
    _moving_disk_video(good, 5)
    bad = tmp_path / "bad.mp4"
    _corrupt_tail(good, bad)
    cal = tmp_path / "cal.json"
    cams = {}
    for i, n in enumerate(["v0", "v1", "bad", "v2", "v3"]):
        T = np.eye(4)
        T[0, 3] = -0.5 * i
        cams[n] = {"K": [[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]], "cam_from_world": T.tolist(),
                   "size": [320, 240]}
    cal.write_text(json.dumps(cams))
    inputs = [videos[0], videos[1], bad, videos[2], videos[3]]
    local_sink, ray_sink = _Calls(), _Calls()
    local = run(inputs, RunConfig(), local_sink, calibration=cal, progress=False)
    cfg = RunConfig(engine=EngineConfig("ray", ray_address=ray_cluster))
    distributed = run(inputs, cfg, ray_sink, calibration=cal, progress=False)
    assert any(c[0] == "frame" for c in local_sink.calls) and any(c[0] == "pair" for c in local_sink.calls)
    assert ray_sink.calls == local_sink.calls
    for res in (local, distributed):
        assert res.offsets_s["bad"] is None
        assert res.unresolved["bad"].startswith("the video could not be read; ") and "corrupt" in res.unresolved["bad"]
        assert "In detail: could not be read:" in res.unresolved["bad"]
        assert sorted(res.cues.videos) == ["v0", "v1", "v2", "v3"]  # the other tasks finished
        assert all(res.cues.videos[n].tracks > 0 for n in ("v0", "v1", "v2", "v3"))
        assert res.offsets_s["v0"] == 0.0  # the reference; v_i starts 2i frames later at 10 fps
        assert all(abs(res.offsets_s[f"v{i}"] - 0.2 * i) < 0.05 for i in (1, 2, 3)), res.offsets_s
    assert distributed.offsets_s == local.offsets_s
    assert distributed.unresolved == local.unresolved
    assert distributed.cues.videos == local.cues.videos


def test_lost_task_is_task_failed_and_the_others_return(ray_cluster):
    """A worker that dies (not a Python error) costs only its own item."""
    from vs_inspect.engine import RayEngine
    with RayEngine(ray_cluster) as eng:
        out = list(eng.map(_die_on_two, [1, 2, 3], shared=None, progress=False))
    assert out[0] == 1 and out[2] == 3
    assert isinstance(out[1], TaskFailed) and "WorkerCrashedError" in out[1].reason


def _die_on_two(shared, x):
    if x == 2:
        os._exit(1)  # the worker process dies, as on a segfault or an OOM kill
    return x


def _ignore_sigterm() -> None:
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def test_a_forked_worker_that_misses_its_sigterm_is_killed_not_waited_for():
    """Pool.terminate waits for its workers without a limit; stop_pool kills those still alive
    after the grace period (here: workers that ignore SIGTERM, as a worker that missed it)."""
    import multiprocessing
    import time

    from vs_inspect.engine import stop_pool

    before = set(multiprocessing.active_children())
    pool = multiprocessing.get_context("fork").Pool(2, initializer=_ignore_sigterm)
    workers = [p for p in multiprocessing.active_children() if p not in before]
    assert len(workers) == 2 and pool.apply(int, ("7",)) == 7
    busy = pool.apply_async(time.sleep, (60,))  # a worker that neither dies nor takes its sentinel
    time.sleep(0.5)
    t0 = time.monotonic()
    stop_pool(pool, workers, grace_s=1.0)
    assert time.monotonic() - t0 < 20  # terminate alone waits out the 60 s
    assert all(p.exitcode is not None for p in workers) and not busy.ready()
