"""RerunSink end to end: a synthetic run with planted failures is recorded to a real .rrd, verified
by the rerun CLI, read back (RrdReader) and compared with result.json; `vs-inspect inspect` must
name the planted failures from the recording alone."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.analysis.record_views import record_frame, record_mask
from vs_inspect.cli import main
from vs_inspect.io.recorded_frames import read_video_frames
from vs_inspect.io.recorded_series import read_static_points
from vs_inspect.io.recording import read_recording
from vs_inspect.io.recording_paths import pair_key
from vs_inspect.io.result import run_result_to_dict, write_run_result
from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.record.rerun_sink import RerunSink
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.sync.config import SyncConfig
from vs_inspect.pipeline.stage12 import sync_bundle
from vs_inspect.result_types import RunResult, SyncResult
from vs_inspect.types import CameraTrack

RERUN = Path(sys.executable).parent / "rerun"
WRONG_POSE_CAMERA = "cam2"


def rerun_verify(path: Path, tmp: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, XDG_CONFIG_HOME=str(tmp / "xdg-config"), XDG_DATA_HOME=str(tmp / "xdg-data"))
    return subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True,
                          env=env, timeout=120)


def run_result(r: SyncResult, **extra) -> RunResult:
    """The RunResult of a bundle-only run (what the pipeline hands the sink's run_summary)."""
    return RunResult(r.reference, r.offsets_s, r.uncertainty_s, r.unresolved_reason, r.pairs, r.solver,
                     r.solve_pairs, r.iterations, r.timings_s, **extra)


def chunk_entities(path: Path) -> set[str]:
    import rerun.chunk as rrc
    return {c.entity_path.lstrip("/") for c in rrc.RrdReader(str(path)).stream().to_chunks()}


@pytest.fixture(scope="module")
def planted_run(tmp_path_factory):
    """5 cameras (one moving), one pair with all-wrong matches, and a wrong pose planted on cam2."""
    tmp = tmp_path_factory.mktemp("planted")
    scene = make_cue_scene(CueSceneConfig(cameras=5, moving=1, variable_rate=0, seconds=5.0,
                                          points_per_object=15, pairs_per_view_pair=120,
                                          no_match_pairs=0, all_wrong_pair=True, seed=3))
    b = scene.bundle
    cam = b.cameras[WRONG_POSE_CAMERA]
    T = cam.cam_from_world.copy()
    R = Rotation.from_euler("xyz", [8, -6, 5], degrees=True).as_matrix()
    T[:3, :3] = R @ T[:3, :3]
    T[:3, 3] = R @ T[:3, 3] + np.array([0.5, 0.2, 0.0])
    bundle = dataclasses.replace(b, cameras={**b.cameras, WRONG_POSE_CAMERA: CameraTrack(cam.K, T)})
    path = tmp / "recordings" / "planted.rrd"
    with RerunSink(path, progress=False) as sink:
        result = sync_bundle(bundle, SyncConfig(), sink=sink, progress=False)
        run = run_result(result, gt_offsets_s=bundle.gt_offsets_s, config={"test": True})
        sink.run_summary(run)
        write_run_result(run, tmp / "out" / "result.json")
    return {"path": path, "result": result, "json": tmp / "out" / "result.json", "scene": scene,
            "bundle": bundle, "stats": sink.stats, "tmp": tmp}


def test_recording_is_complete_and_verifies(planted_run):
    path = planted_run["path"]
    assert path.is_file()
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary file left
    proc = rerun_verify(path, planted_run["tmp"])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    ents = chunk_entities(path)
    a, b = planted_run["result"].pairs[0].a, planted_run["result"].pairs[0].b
    for e in ("meta/result_json", "meta/recording_json", "meta/cue_bundle", "sync/graph", "sync/offsets",
              f"pairs/{a}__{b}/landscape/energy", f"pairs/{a}__{b}/decision",
              f"pairs/{a}__{b}/epipolar/lines", f"world/cameras/{WRONG_POSE_CAMERA}",
              "videos/cam0/tracks", "log/decisions"):
        assert e in ents, e
    assert any(e.startswith("world/trajectories/") for e in ents)
    pts, _ = read_static_points(path)
    assert pts.shape == (0, 3)  # a cue bundle has no static reconstruction
    assert any(e.startswith("sync/solve/residual_ms/") for e in ents)


def test_readback_equals_result_json(planted_run):
    rec = read_recording(planted_run["path"])
    on_disk = json.loads(planted_run["json"].read_text())
    assert run_result_to_dict(rec.result) == on_disk  # the complete result, exactly
    assert rec.meta["format"] == "vs-inspect-recording"
    assert rec.config == {"test": True}
    assert {v.name for v in rec.videos} == set(on_disk["offsets_s"])
    for p in on_disk["pairs"]:
        key = pair_key(p["a"], p["b"])
        # decision text: verdict and reason
        md = rec.decisions[key]
        assert ("ACCEPTED" if p["accepted"] else "REJECTED") in md
        assert p["reason"] in md
        series = rec.landscapes.get(key, {})
        land = p["landscape"]
        finite = [(o, e) for o, e in zip(land["offsets_s"], land["energy"]) if e is not None]
        if not finite:
            assert "energy" not in series
            continue
        # the logged landscape is the landscape of result.json (offsets on whole ms)
        np.testing.assert_array_equal(series["energy"].offset_ms, [round(o * 1000) for o, _ in finite])
        np.testing.assert_allclose(series["energy"].value, [e for _, e in finite], rtol=0, atol=0)
        # minima: same offsets (ms) and energies as result.json
        want = sorted(zip([round(o * 1000) for o in p["minima_offsets_s"]], p["minima_energy"]))
        got = list(zip(series["minima"].offset_ms.tolist(), series["minima"].value.tolist()))
        assert got == want
        if p["offset_s"] is not None and p["best_energy"] is not None:
            assert series["chosen"].offset_ms.tolist() == [round(p["offset_s"] * 1000)]
            assert series["chosen"].value.tolist() == [p["best_energy"]]
        assert "truth" in series  # the ground truth is known in this scene
    # solve iterations: residuals and weights per accepted pair
    its = on_disk["solve"]["iterations"]
    for e, (a, b) in enumerate(on_disk["solve"]["pairs"]):
        key = pair_key(a, b)
        np.testing.assert_allclose(rec.solve["residual_ms"][key], [1000 * it["residual_s"][e] for it in its])
        np.testing.assert_allclose(rec.solve["weight"][key], [it["weight"][e] for it in its])


def test_inspect_names_planted_failures(planted_run, capsys):
    # the recording alone: copy it somewhere else first (as if sent from another machine)
    other = planted_run["tmp"] / "elsewhere" / "sent.rrd"
    other.parent.mkdir()
    shutil.copy(planted_run["path"], other)
    assert main(["inspect", str(other)]) == 0
    out = capsys.readouterr().out
    suspects = out.split("suspects:")[1]
    a, b = planted_run["scene"].all_wrong_pair
    assert f"{a}__{b}" in suspects  # the pair whose matches are all wrong
    assert f"{WRONG_POSE_CAMERA}:" in suspects and "camera pose" in suspects  # the wrong pose
    for name, off in planted_run["result"].offsets_s.items():
        assert name in out
        if off is not None:
            assert f"{off:+.4f}" in out
    for p in planted_run["result"].pairs:
        assert p.decision.reason in out


def test_inspect_pair_prints_minima(planted_run, capsys):
    p = next(p for p in planted_run["result"].pairs if len(p.minima_idx) >= 1)
    assert main(["inspect", str(planted_run["path"]), "--pair", p.b, p.a]) == 0
    out = capsys.readouterr().out.split(f"pair {p.a} → {p.b}")[1]
    assert "the negative" in out
    for i in p.minima_idx:
        assert f"Δ = {p.offsets_s[i]:+.4f} s" in out
    assert main(["inspect", str(planted_run["path"]), "--pair", "cam0", "nope"]) == 2


def test_abort_on_exception_leaves_nothing(tmp_path):
    scene = make_cue_scene(CueSceneConfig(cameras=2, moving=0, variable_rate=0, seconds=3.0,
                                          points_per_object=5, no_match_pairs=0, all_wrong_pair=False))
    target = tmp_path / "rec" / "x.rrd"
    with pytest.raises(RuntimeError):
        with RerunSink(target, progress=False) as sink:
            sink.bundle(scene.bundle)
            raise RuntimeError("stage failed")
    assert not target.exists()
    assert list(target.parent.iterdir()) == []


def _write_h264(path: Path, frames: list[np.ndarray], fps: int) -> None:
    import av
    with av.open(str(path), "w") as c:
        s = c.add_stream("libx264", rate=fps)
        s.width, s.height, s.pix_fmt = frames[0].shape[1], frames[0].shape[0], "yuv420p"
        for f in frames:
            for pkt in s.encode(av.VideoFrame.from_ndarray(f, format="bgr24")):
                c.mux(pkt)
        for pkt in s.encode():
            c.mux(pkt)


def test_frames_masks_and_video_asset(tmp_path):
    """Real video files decoded by real decoders: H.264 is embedded as an AssetVideo with frame
    references, an MJPG file is logged as downscaled JPEG frames, masks as segmentation images."""
    import cv2
    scene = make_cue_scene(CueSceneConfig(cameras=2, moving=0, variable_rate=0, seconds=2.0,
                                          points_per_object=5, no_match_pairs=0, all_wrong_pair=False,
                                          fps_choices=(10.0,)))
    b = scene.bundle
    paths = {}
    rng = np.random.default_rng(0)
    for v in b.videos:
        frames = []
        for k in range(v.num_frames):
            img = np.full((v.height // 4, v.width // 4, 3), 40, np.uint8)
            cv2.circle(img, (20 + 5 * k, 40), 12, (0, 200, 255), -1)
            img[:8, :8] = rng.integers(0, 255, (8, 8, 3))
            frames.append(cv2.resize(img, (v.width, v.height)))
        if v.name == "cam0":
            paths[v.name] = tmp_path / "cam0.mp4"
            _write_h264(paths[v.name], frames, int(v.fps))
        else:
            paths[v.name] = tmp_path / "cam1.avi"
            w = cv2.VideoWriter(str(paths[v.name]), cv2.VideoWriter_fourcc(*"MJPG"), v.fps, (v.width, v.height))
            for f in frames:
                w.write(f)
            w.release()
    out = tmp_path / "frames.rrd"
    with RerunSink(out, options=RecordOptions(max_image_width_px=320), progress=False) as sink:
        for v in b.videos:
            sink.video(v, str(paths[v.name]))
            cap = cv2.VideoCapture(str(paths[v.name]))
            k = 0
            while True:
                ok, img = cap.read()
                if not ok:
                    break
                sink.video_frame(v.name, k, record_frame(img, sink.options))
                mask = (cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) > 100).astype(np.int32)
                sink.dynamic_mask(v.name, k, record_mask(mask, sink.options))
                k += 1
            assert k == v.num_frames
        result = sync_bundle(b, SyncConfig(), sink=sink, progress=False)
    assert rerun_verify(out, tmp_path).returncode == 0
    ents = chunk_entities(out)
    assert "videos/cam0/video" in ents  # H.264 embedded as a video asset
    assert "world/cameras/cam0/image" in ents  # its frames on the 3D image plane (references)
    assert "videos/cam1/image" in ents and "videos/cam0/image" not in ents  # MJPG -> JPEG frames
    assert {"videos/cam0/mask", "videos/cam1/mask"} <= ents
    import rerun.chunk as rrc
    store = rrc.RrdReader(str(out)).stream().collect()
    tab = store.reader("frame", contents="/videos/cam1/image").to_arrow_table()
    assert tab.num_rows == b.video("cam1").num_frames
    if result.offsets_s.get("cam1") is not None:  # synchronized: frames also on the global time axis
        assert "time" in store.reader("time", contents="/videos/cam1/image").to_arrow_table().column_names
    blob = [c for c in tab.column_names if c.endswith("EncodedImage:blob")][0]
    jpg = np.asarray(tab.column(blob)[0].as_py()[0], dtype=np.uint8)
    img = cv2.imdecode(jpg, cv2.IMREAD_COLOR)
    assert img.shape[1] == 320  # downscaled to the configured width
    frames = read_video_frames(out, "cam1")
    assert sorted(frames) == list(range(b.video("cam1").num_frames))
    assert all(f.shape[1] == 320 for f in frames.values())
    assert read_video_frames(out, "cam0") == {}  # an embedded video asset, not JPEG frames


def test_real_videos_recording_verifies(shared_data, tmp_path):
    """The caliscope webcams (mpeg4, 720p): real frames decoded by PyAV, real calibrated cameras,
    masks from frame differences; the recording passes `rerun rrd verify` and reads back."""
    import cv2

    from vs_inspect.io.calibration import load_calibration
    from vs_inspect.io.video import iter_frames, open_video
    root = shared_data / "caliscope_post_optimization"
    paths = sorted((root / "calibration" / "extrinsic").glob("cam_*.mp4"))[:2]
    sources = [open_video(p) for p in paths]
    calib = load_calibration(root / "camera_array.toml", [s.info.name for s in sources])
    cams = {n: CameraTrack(c.K, c.cam_from_world) for n, c in calib.items()}
    out = tmp_path / "caliscope.rrd"
    with RerunSink(out, progress=False) as sink:
        for s in sources:
            sink.video(s.info, str(s.path))
            prev = None
            for k, img in iter_frames(s):
                sink.video_frame(s.info.name, k, record_frame(img, sink.options))
                grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
                if prev is not None:
                    moving = (cv2.absdiff(grey, prev) > 25).astype(np.int32)
                    sink.dynamic_mask(s.info.name, k, record_mask(moving, sink.options))
                prev = grey
        sink.cameras(cams, None, None)
    assert rerun_verify(out, tmp_path).returncode == 0
    ents = chunk_entities(out)
    for s in sources:
        n = s.info.name
        assert {f"videos/{n}/image", f"videos/{n}/mask", f"world/cameras/{n}"} <= ents
    frames = read_video_frames(out, sources[0].info.name)
    assert len(frames) == sources[0].info.num_frames and frames[0].shape == (360, 640, 3)
    assert out.stat().st_size < 20e6


def _texts(path: Path) -> dict[str, str]:
    import rerun.chunk as rrc
    out = {}
    for c in rrc.RrdReader(str(path)).stream().to_chunks():
        rb = c.to_record_batch()
        if "TextDocument:text" in rb.schema.names:
            v = rb.column("TextDocument:text")[0].as_py()
            out[c.entity_path.lstrip("/")] = v[0] if isinstance(v, list) else v
    return out


def test_guide_pairs_table_and_loop_closure(planted_run):
    """What a person reads first: the guide, every pair with its verdict and reason (failed pairs
    first, as the containers), and the loop-closure residual of every triangle of pairs."""
    from vs_inspect.record.blueprint import pair_order
    texts = _texts(planted_run["path"])
    guide = texts["guide"]
    assert "offset_ms" in guide and "ffmpeg" in guide and "time" in guide
    result = planted_run["result"]
    table = texts["sync/pairs"].split("|---|---|---|---|---|---|---|")[1].strip().splitlines()
    assert len(table) == len(result.pairs)
    for row, p in zip(table, pair_order(result.pairs)):
        assert f"{p.a} → {p.b}" in row and p.decision.reason in row
        assert row.startswith("| ✓" if p.decision.accepted else "| ✗")
    rejected = [not p.decision.accepted for p in pair_order(result.pairs)]
    assert rejected == sorted(rejected, reverse=True)  # failed pairs first
    a, b = planted_run["scene"].all_wrong_pair
    assert not next(p for p in result.pairs if {p.a, p.b} == {a, b}).decision.accepted
    loops = texts["sync/loops"]
    n = len(result.offsets_s)
    rows = [r for r in loops.splitlines() if r.startswith("| cam")]
    assert 0 < len(rows) <= n * (n - 1) * (n - 2) // 6
    res = [abs(float(r.split("|")[2])) for r in rows]
    assert res == sorted(res, reverse=True)


def test_palette_keeps_green_and_red_for_the_verdict():
    """Instances, cameras and pairs never take the accepted/rejected colours or anything close;
    a mask's background (id 0) is transparent."""
    from vs_inspect.record.rerun_sink import ACCEPTED, PALETTE, REJECTED, annotation_context, distance_colors
    import colorsys

    def hue_sat(c):
        h, _, s = colorsys.rgb_to_hls(*(np.asarray(c) / 255.0))
        return 360 * h, s

    for c in PALETTE:
        h, s = hue_sat(c)
        for v in (ACCEPTED, REJECTED):
            hv, _ = hue_sat(v)
            gap = min(abs(h - hv), 360 - abs(h - hv))
            assert gap > 25 or s < 0.25, (c.tolist(), v, gap)  # another hue, or a grey/white
        assert not 75 < h < 170 or s < 0.25, c.tolist()  # nothing green
    ctx = annotation_context(3).context.as_arrow_array().to_pylist()[0]
    colours = {d["class_id"]: d["class_description"]["info"]["color"] for d in ctx}
    assert colours[0] & 0xFF == 0  # RGBA: alpha 0
    assert all(colours[k] & 0xFF == 255 and colours[k] >> 8 == int.from_bytes(bytes(PALETTE[k % len(PALETTE)]), "big")
               for k in (1, 2, 3))  # instance k: PALETTE[k], as the tracks (instance_colors)
    ramp = distance_colors(np.array([0.0, 5.0, 10.0, np.nan]), 10.0).astype(int)
    assert ramp[0].tolist() == [253, 234, 69] and ramp[2].tolist() == [70, 90, 210]
    assert ramp[3].tolist() == [150, 150, 150]


def test_drift_run_records_the_rate_landscape_image(tmp_path):
    """--drift on a pose-free pair: the (Δ, rate) energy is in the recording as an RGB image and
    a tensor under the pair's entity path, the file verifies, and the image reads back."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "pipeline"))
    from test_stage12_posefree import CFG, drone_bundle

    from vs_inspect.io.recorded_series import read_rate_landscape
    from vs_inspect.io.recording_paths import pair_rate_landscape_path
    from vs_inspect.sync.config import DriftConfig

    full = drone_bundle()
    keep = ("c0", "c1")
    b = dataclasses.replace(full, videos=full.videos[:2], cameras={k: full.cameras[k] for k in keep},
                            tracks={k: full.tracks[k] for k in keep}, pairs={keep: full.pairs[keep]},
                            gt_offsets_s={k: full.gt_offsets_s[k] for k in keep},
                            gt_drift_ppm={k: full.gt_drift_ppm[k] for k in keep}, pose_free=frozenset(keep))
    path = tmp_path / "drift.rrd"
    with RerunSink(path, progress=False) as sink:
        res = sync_bundle(b, dataclasses.replace(CFG, drift=DriftConfig(enabled=True)), sink=sink, progress=False)
    land = res.pairs[0]
    assert land.rate_landscape is not None
    proc = rerun_verify(path, tmp_path)
    assert proc.returncode == 0, proc.stderr
    base = pair_rate_landscape_path("c0", "c1")
    assert {f"{base}/image", f"{base}/energy", f"{base}/axes"} <= chunk_entities(path)
    img, energy = read_rate_landscape(path, "c0", "c1")
    rl = land.rate_landscape
    assert energy.shape == rl.energy.shape and np.allclose(energy, rl.energy, rtol=1e-6)
    assert img.dtype == np.uint8 and img.shape[2] == 3
    assert img.shape[0] % len(rl.rates_ppm) == 0 and img.shape[1] % len(rl.offsets_s) == 0
    # the lowest energy cell is the darkest (viridis), the highest the brightest
    cell = img.shape[0] // len(rl.rates_ppm)
    lum = img[cell // 4::cell, cell // 4::cell].astype(float).sum(axis=2)
    lo, hi = np.unravel_index(np.nanargmin(rl.energy), rl.energy.shape), np.unravel_index(np.nanargmax(rl.energy), rl.energy.shape)
    assert lum[lo] < lum[hi]


def test_keyframe_matches_per_pair_are_recorded(tmp_path):
    """Stage 0's descriptor matches per keyframe pair (match_tracks on a real texture seen by two
    'videos', one shifted): the counts add up to the pair's matches, and the recording holds them
    as a series on the keyframe_pair timeline plus a (Ka,Kb) grid, readable back."""
    from vs_inspect.cues.pairing.descriptors import extract_keyframe_features, match_tracks

    from ..cues.scenes import texture

    img = texture(240, 320, 5, blur=1.5)
    frames_a = np.stack([img, np.roll(img, 3, axis=1), np.zeros_like(img)])  # keyframe 2: blank, no features
    frames_b = np.stack([np.roll(img, 6, axis=0), np.roll(img, -4, axis=1)])
    fa = extract_keyframe_features(frames_a, None, np.arange(3), np.zeros((0, 3, 2)))
    fb = extract_keyframe_features(frames_b, None, np.arange(2), np.zeros((0, 2, 2)))
    _, ps = match_tracks("a", "b", fa, fb, np.zeros(0, int), np.zeros(0, int))
    counts = ps.keyframe_matches
    assert counts.shape == (3, 2) and counts.sum() == ps.matches
    assert (counts[:2] > 50).all() and (counts[2] == 0).all(), counts
    out = tmp_path / "matches.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.pair_matches("a", "b", fa.keyframes, fb.keyframes, counts)
    assert rerun_verify(out, tmp_path).returncode == 0
    assert {"pairs/a__b/keyframe_matches", "pairs/a__b/keyframe_matches/grid"} <= chunk_entities(out)
    import rerun.chunk as rrc
    store = rrc.RrdReader(str(out)).stream().collect()
    tab = store.reader("keyframe_pair", contents="/pairs/a__b/keyframe_matches").to_arrow_table()
    col = [c for c in tab.column_names if c.endswith("Scalars:scalars")][0]
    got = np.array([v[0] for v in tab.column(col).to_pylist()])
    order = np.argsort(np.array(tab.column("keyframe_pair").to_pylist()))
    assert np.array_equal(got[order], counts.ravel())


def test_point_transfer_check_is_recorded(tmp_path):
    """Stage 0's point-transfer check of an unsure camera: its share over the camera's candidate
    offsets on offset_ms, the joint vote's and the transfer's offsets as points, readable back."""
    import rerun.chunk as rrc

    offsets = np.arange(-1.0, 1.0, 0.02)
    share = np.exp(-((offsets - 0.3) / 0.05) ** 2)
    out = tmp_path / "transfer.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.transfer_landscape("cam.2", offsets, share, 0.25, 0.3, False)
    assert rerun_verify(out, tmp_path).returncode == 0
    base = "cues/transfer/cam_2"
    assert {f"{base}/share", f"{base}/joint", f"{base}/peak"} <= chunk_entities(out)
    store = rrc.RrdReader(str(out)).stream().collect()
    tab = store.reader("offset_ms", contents=f"/{base}/share").to_arrow_table()
    col = [c for c in tab.column_names if c.endswith("Scalars:scalars")][0]
    got = np.array([v[0] for v in tab.column(col).to_pylist()])
    ms = np.array(tab.column("offset_ms").to_pylist())
    assert np.allclose(got[np.argsort(ms)], share) and ms.min() == -1000
    peak = store.reader("offset_ms", contents=f"/{base}/peak").to_arrow_table()
    assert peak.column("offset_ms").to_pylist() == [300]


def _view_names(container) -> list[str]:
    """The names of every view inside a blueprint container, nested containers included."""
    import rerun.blueprint as rrb
    out = []
    for x in container.contents:
        out += _view_names(x) if isinstance(x, rrb.Container) else [x.name]
    return out


def test_three_view_check_is_recorded_with_its_own_overview_tab(tmp_path):
    """Stage 0's three-view check of a sure camera: the trajectories followed over its candidate
    offsets on offset_ms and the joint offset as a point; the overview gets a tab for it."""
    import rerun.chunk as rrc

    offsets = np.arange(-1.0, 1.0, 0.02)
    supporters = np.where(np.abs(offsets - 0.4) < 0.03, 12.0, 1.0)
    out = tmp_path / "three_view.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.three_view_landscape("cam.1", offsets, supporters, -0.5, False)
        bp = sink.blueprint(["cam.1"])
    assert rerun_verify(out, tmp_path).returncode == 0
    base = "cues/three_view/cam_1"
    assert {f"{base}/supporters", f"{base}/joint"} <= chunk_entities(out)
    store = rrc.RrdReader(str(out)).stream().collect()
    tab = store.reader("offset_ms", contents=f"/{base}/supporters").to_arrow_table()
    col = [c for c in tab.column_names if c.endswith("Scalars:scalars")][0]
    ms = np.array(tab.column("offset_ms").to_pylist())
    assert np.array_equal(np.array([v[0] for v in tab.column(col).to_pylist()])[np.argsort(ms)], supporters)
    joint = store.reader("offset_ms", contents=f"/{base}/joint").to_arrow_table()
    assert joint.column("offset_ms").to_pylist() == [-500]
    assert "three-view check (Stage 0: sure cameras)" in _view_names(bp.root_container)


def test_pairing_votes_are_recorded_on_the_pairs_offset_axis(tmp_path):
    """Stage 0's geometric votes of a pair: z-scores and counts over Δ_ab on offset_ms (the
    landscape's axis) and the kept Δ as a point; the overview gets a 'pairing votes' tab."""
    import rerun.chunk as rrc

    offsets = np.arange(-1.0, 1.0, 0.01)
    votes = np.where(np.abs(offsets - 0.25) < 0.02, 40.0, 2.0)
    z = (votes - 2.0) / 1.5
    out = tmp_path / "votes.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.pair_votes("a", "b", offsets, votes, z, 0.25)
        bp = sink.blueprint(["a", "b"])
    assert rerun_verify(out, tmp_path).returncode == 0
    assert {"pairs/a__b/votes/z", "pairs/a__b/votes/count", "pairs/a__b/votes/chosen"} <= chunk_entities(out)
    store = rrc.RrdReader(str(out)).stream().collect()
    tab = store.reader("offset_ms", contents="/pairs/a__b/votes/count").to_arrow_table()
    col = [c for c in tab.column_names if c.endswith("Scalars:scalars")][0]
    ms = np.array(tab.column("offset_ms").to_pylist())
    got = np.array([v[0] for v in tab.column(col).to_pylist()])[np.argsort(ms)]
    assert np.array_equal(got, votes) and ms.min() == -1000
    chosen = store.reader("offset_ms", contents="/pairs/a__b/votes/chosen").to_arrow_table()
    assert chosen.column("offset_ms").to_pylist() == [250]
    assert "pairing votes (Stage 0, z per Δ)" in _view_names(bp.root_container)


def test_the_appearance_pairs_landscape_is_recorded_beside_the_full_one(planted_run, tmp_path):
    """A pair whose unchecked track pairs were checked: the landscape of its other track pairs
    alone (grey) and that landscape's minimum under the pair's landscape, and a row in its decision."""
    land = next(p for p in planted_run["result"].pairs if len(p.minima_idx))
    e = np.linspace(3.0, 1.0, len(land.offsets_s))
    e[::7] = np.nan
    land = dataclasses.replace(land, confirm_energy=e, confirm_offset_s=float(land.offsets_s[-1]))
    out = tmp_path / "confirm.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.pair_landscape(land)
    assert rerun_verify(out, tmp_path).returncode == 0
    base = f"pairs/{land.a}__{land.b}/landscape"
    assert {f"{base}/appearance_only", f"{base}/appearance_only_best"} <= chunk_entities(out)
    rec = read_recording(out)
    key = pair_key(land.a, land.b)
    series = rec.landscapes[key]["appearance_only"]
    full = land.energy[np.isfinite(land.energy)]  # drawn over the full landscape's range
    assert len(series.value) == int(np.isfinite(e).sum())
    assert np.isclose(series.value.max(), full.max()) and np.isclose(series.value.min(), full.min())
    assert np.all(np.diff(series.value) < 0)  # the shape kept (a falling line here)
    assert rec.landscapes[key]["appearance_only_best"].offset_ms.tolist() == [round(land.offsets_s[-1] * 1000)]
    md = rec.decisions[key]
    assert f"| appearance pairs alone | minimum {land.offsets_s[-1]:+.4f} s |" in md, md


def test_a_run_that_stops_in_stage0_shows_its_stills_and_reasons_on_offset_ms(tmp_path):
    """Stage 0 logged votes on offset_ms and then refused every camera (no Stage 1): the videos'
    stills and Stage 0's events are on offset_ms, where the viewer opens, not only elsewhere."""
    import rerun.chunk as rrc

    from vs_inspect.types import VideoInfo

    info = VideoInfo("a", 64, 48, 10, np.arange(10) / 10.0, fps=10.0)
    offsets = np.arange(-0.5, 0.5, 0.1)
    out = tmp_path / "stage0.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.video(info, "a.mp4")
        for k in range(info.num_frames):
            sink.video_frame("a", k, np.full((48, 64, 3), 20 * k, np.uint8))
        sink.pair_votes("a", "b", offsets, np.ones(len(offsets)), np.zeros(len(offsets)), None)
        sink.stage_event("cameras", "a: camera from the moving points refused")
    assert rerun_verify(out, tmp_path).returncode == 0
    store = rrc.RrdReader(str(out)).stream().collect()
    logs = store.reader("offset_ms", contents="/log/stage0").to_arrow_table()
    body = [c for c in logs.column_names if c.endswith("TextLog:text")][0]
    assert [v[0] for v in logs.column(body).to_pylist()] == ["cameras: a: camera from the moving points refused"]
    assert logs.column("offset_ms").to_pylist() == [-500]
    still = [e for e in chunk_entities(out) if e.startswith("videos/a/still")]
    assert still, chunk_entities(out)
    assert store.reader("offset_ms", contents=f"/{still[0]}").to_arrow_table().num_rows >= 1


def test_inspect_of_a_run_with_no_pair_says_none_was_evaluated(tmp_path, capsys):
    """A run that stopped in Stage 0 has no pair: inspect says so and names each video's reason,
    instead of "every pair is accepted and agrees with the solution"."""
    from vs_inspect.result_types import RunResult

    why = "camera from the moving points refused: its own epipolar votes contradict the offsets"
    result = RunResult("a", {"a": None, "b": None, "c": None}, {"a": None, "b": None, "c": None},
                       {n: why for n in "abc"}, (), "irls", (), (), {})
    out = tmp_path / "nopairs.rrd"
    with RerunSink(out, progress=False) as sink:
        sink.stage_event("cameras", f"a: {why}")
        sink.run_summary(result)
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "none evaluated: Stage 0 left no pair to search" in text
    assert "every pair is accepted" not in text
    assert text.count(why) >= 3


def test_the_3d_view_is_left_out_when_no_camera_was_logged(tmp_path):
    """Stage 0 refused every camera: no 3D view that would open empty; with cameras, it is there."""
    import rerun.blueprint as rrb

    from vs_inspect.types import CameraTrack

    def views(bp):
        def walk(c):
            out = []
            for x in c.contents:
                out += walk(x) if isinstance(x, rrb.Container) else [x.name]
            return out
        return walk(bp.root_container)

    with RerunSink(tmp_path / "none.rrd", progress=False) as sink:
        assert "3D" not in views(sink.blueprint(["a"]))
    K = np.array([[100.0, 0, 32], [0, 100.0, 24], [0, 0, 1]])
    with RerunSink(tmp_path / "cams.rrd", progress=False) as sink:
        sink.cameras({"a": CameraTrack(K, np.eye(4))}, None, None)
        assert "3D" in views(sink.blueprint(["a"]))


def test_the_offsets_panel_gives_every_null_in_a_few_words_and_in_full(tmp_path):
    """The run's summary rewrites the offsets panel: a video Stage 0 left out (not in Stage 2's
    table) is listed too, each null with its headline in the table and its whole reason below."""
    from vs_inspect.io.recording_paths import SYNC_OFFSETS
    from vs_inspect.io.rrd_chunks import _chunks, _first_text

    full = "no reconstruction: too few matches; from the moving points: half the pairs 16.7 px off (also tried: ...)"
    res = RunResult("a", {"a": 0.0, "b": 0.5, "c": None}, {"a": 0.0, "b": 0.01, "c": None},
                    {"c": full}, (), "irls", (), (), {"total_s": 1.0},
                    unresolved_headline={"c": "no reconstruction: too few matches"})
    path = tmp_path / "run.rrd"
    with RerunSink(path, progress=False) as sink:
        sink.run_summary(res)
        # no video was placed in time and no pair searched: the layout opens on frame
        assert sink.blueprint(["a", "b", "c"]).time_panel.timeline == "frame"
    texts = [_first_text(ch.to_record_batch()) for ch in _chunks(path, [f"/{SYNC_OFFSETS}/**"])]
    md = next(t for t in texts if t)
    rows = {line.split("|")[1].strip(): line for line in md.splitlines() if line.startswith("| ")}
    assert set(rows) >= {"a", "b", "c"}
    assert rows["c"].rstrip(" |").endswith("no reconstruction: too few matches") and full not in rows["c"]
    assert md.endswith(f"**c**: no reconstruction: too few matches\n\n> in full: {full}")


def test_a_pair_without_a_landscape_gets_its_decision_alone(tmp_path):
    """A pair with no track pair (Stage 0 refused every camera) has no finite
    energy and no epipolar view: its container holds the decision only, not two empty panels."""
    import rerun.blueprint as rrb

    from vs_inspect.result_types import PairDecision, PairLandscape

    land = PairLandscape("a", "b", np.linspace(-1, 1, 5), np.full(5, np.nan), np.zeros(5, int), np.array([], int),
                         math.nan, math.nan, math.nan, 0,
                         PairDecision(False, "no cross-view track pairs", 0.0, 0.0, 0, 0, False))
    with RerunSink(tmp_path / "r.rrd", progress=False) as sink:
        sink.pair_landscape(land)
        middle = sink.blueprint(["a", "b"]).root_container.contents[1]
        (container,) = middle.contents
        kinds = [type(v).__name__ for v in container.contents]
        assert kinds == ["TextDocumentView"], kinds
        assert not isinstance(container.contents[0], rrb.Container)


def _offsets_texts(path: Path) -> list[str]:
    """Every text the file holds for the offsets panel, in the order written (the raw chunks: a
    store keeps only the last static value, which would hide a second write)."""
    import rerun.chunk as rrc

    from vs_inspect.io.recording_paths import SYNC_OFFSETS
    from vs_inspect.io.rrd_chunks import _first_text
    chunks = [c for c in rrc.RrdReader(str(path)).stream().to_chunks() if c.entity_path.lstrip("/") == SYNC_OFFSETS]
    return [t for c in chunks if (t := _first_text(c.to_record_batch()))]


def test_the_offsets_table_is_logged_once_and_stage2s_when_no_summary_follows(planted_run, tmp_path):
    """The offsets table is written once, when the recording closes: the run's summary where there
    is one (the planted run), else Stage 2's table (a bundle synchronized with no summary after it)."""
    (summary_md,) = _offsets_texts(planted_run["path"])
    assert summary_md.startswith("## Offsets (reference ")
    assert all(f"| {v} |" in summary_md for v in planted_run["result"].offsets_s)

    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=3.0, points_per_object=10,
                                          pairs_per_view_pair=60, no_match_pairs=0, seed=5))
    path = tmp_path / "stage2_only.rrd"
    with RerunSink(path, progress=False) as sink:
        result = sync_bundle(scene.bundle, SyncConfig(), sink=sink, progress=False)
    (stage2_md,) = _offsets_texts(path)
    assert all(f"| {v} |" in stage2_md for v in result.offsets_s)
