"""Computations behind the report: from a run's result and its cue bundle to ReportData.

Everything the figures show is computed here (epipolar lines, Sampson errors, triangulated
trajectories, pair choice), so that the renderers (report/) only draw. The inputs come from a run
folder (result.json and the cue bundle it names) or from a recording alone (its result, its
embedded cue bundle and its frames), both read by io/.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.epipolar import camera_centers, epipolar_residual, fundamental_from_cameras, project
from ..geometry.timing import frame_brackets, interpolate_intrinsics, interpolate_poses
from ..geometry.triangulate import triangulate_dlt
from ..types import CueBundle, RunResult
from ..report.data import (CameraView, EpipolarPanel, EpipolarState, Mosaic, MosaicTile, PairView,
                   ReportData, Trajectory, VideoClock)

log = logging.getLogger(__name__)

WRONG_SHIFT_S = 0.5  # the "wrong" offset of the epipolar panel is the chosen one ± this
MAX_EPIPOLAR_MATCHES = 16  # matches drawn in the epipolar panel
MAX_TRAJECTORIES = 300  # triangulated tracks drawn in the 3D scene
TRAJ_PAIRS = 3  # accepted pairs (best contrast first) triangulated for the 3D scene
MAX_REPROJ_PX = 4.0  # a triangulated sample is kept when it reprojects this close in both views
MIN_RAY_ANGLE_DEG = 3.0  # ... and when its two viewing rays meet at least at this angle


def _opt(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def pair_views(result: RunResult, gt: dict[str, float] | None) -> tuple[PairView, ...]:
    """PairView of every pair of the result, with the solved and the true Δ_ab."""
    offs = result.offsets_s
    out = []
    for p in result.pairs:
        a, b = p.a, p.b
        sa, sb = offs.get(a), offs.get(b)
        solved = sb - sa if sa is not None and sb is not None else None
        true = gt[b] - gt[a] if gt and a in gt and b in gt else None
        offsets = np.asarray(p.offsets_s, dtype=np.float64)
        energy = np.asarray(p.energy, dtype=np.float64)
        out.append(PairView(
            a, b, offsets, energy, offsets[p.minima_idx], energy[p.minima_idx],
            bool(p.decision.accepted), p.decision.reason, _opt(p.best_offset_s),
            _opt(p.uncertainty_s), solved, true, int(p.num_track_pairs),
            float(p.decision.contrast) if math.isfinite(p.decision.contrast) else 0.0))
    return tuple(out)


def video_clocks(bundle: CueBundle, paths: dict[str, str] | None = None) -> tuple[VideoClock, ...]:
    paths = paths or {}
    return tuple(VideoClock(v.name, v.width, v.height, v.num_frames, float(v.timestamps_s[0]),
                            float(v.timestamps_s[-1]), v.fps, paths.get(v.name)) for v in bundle.videos)


def camera_views(bundle: CueBundle) -> tuple[CameraView, ...]:
    out = []
    for v in bundle.videos:
        cam = bundle.cameras[v.name]
        T = cam.cam_from_world.reshape(-1, 4, 4)
        if cam.valid is not None and T.shape[0] > 1:
            T = T[cam.valid]
        out.append(CameraView(v.name, cam.K, T, v.width, v.height))
    return tuple(out)


def choose_pair(pairs: tuple[PairView, ...], requested: tuple[str, str] | None) -> PairView | None:
    """The requested pair (either order) or the accepted pair with the sharpest landscape."""
    if requested:
        a, b = requested
        for p in pairs:
            if (p.a, p.b) == (a, b) or (p.a, p.b) == (b, a):
                return p
        known = ", ".join(p.key for p in pairs)
        raise ValueError(f"--pair {a} {b}: no such pair in the result (pairs: {known})")
    ok = [p for p in pairs if p.accepted and p.chosen_offset_s is not None]
    if not ok:
        ok = [p for p in pairs if p.chosen_offset_s is not None]
    return max(ok, key=lambda p: (p.contrast, p.num_track_pairs)) if ok else None


# ---- sampling a video at another video's moments ------------------------------------------


def _sample_b(bundle: CueBundle, b: str, rows: np.ndarray, query_s: np.ndarray):
    """b's track rows at local times query_s (Q,): xy (len(rows),Q,2), K (Q,3,3), pose (Q,4,4).

    Linear interpolation between the bracketing frames; NaN where b has no frame or no point.
    """
    vb, cam, xy = bundle.video(b), bundle.cameras[b], bundle.tracks[b].xy
    k, w = frame_brackets(vb.timestamps_s, query_s)
    ok = k >= 0
    kc = np.clip(k, 0, max(vb.num_frames - 2, 0))
    k1 = np.minimum(kc + 1, vb.num_frames - 1)
    x = xy[rows]
    out = x[:, kc] + w[None, :, None] * (x[:, k1] - x[:, kc])
    out[:, ~ok] = np.nan
    if cam.cam_from_world.ndim == 3:
        pose = interpolate_poses(cam.cam_from_world, k, w)
    else:
        pose = np.broadcast_to(cam.cam_from_world, (len(k), 4, 4)).copy()
        pose[~ok] = np.nan
    K = interpolate_intrinsics(cam.K, kc, w)
    if cam.valid is not None:
        bad = ~(cam.valid[kc] & cam.valid[k1])
        pose[bad] = np.nan
        out[:, bad] = np.nan
    return out, K, pose


def _epipolar_state(bundle: CueBundle, a: str, b: str, rows: np.ndarray, frame: int,
                    offset_s: float, show: np.ndarray) -> EpipolarState:
    va = bundle.video(a)
    t_a = float(va.timestamps_s[frame])
    ia, ib = rows[:, 0], rows[:, 1]
    xa = bundle.tracks[a].xy[ia, frame].astype(np.float64)  # (P,2)
    xb, K_b, T_b = _sample_b(bundle, b, ib, np.array([t_a - offset_s]))
    xb = xb[:, 0]
    K_a = bundle.cameras[a].K_at(np.array([frame]))[0]
    T_a = bundle.cameras[a].pose_at(np.array([frame]))[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        F = fundamental_from_cameras(K_a, T_a, K_b[0], T_b[0])
        samp = epipolar_residual(F, xa, xb, "sampson")
        lines = np.einsum("ij,nj->ni", F, np.concatenate([xb, np.ones((len(xb), 1))], 1))
    fin = samp[np.isfinite(samp)]
    return EpipolarState(float(offset_s), xa[show], lines[show], xb[show], samp[show],
                         float(np.median(fin)) if fin.size else float("nan"))


def epipolar_panel(bundle: CueBundle, pair: PairView, image_bgr: np.ndarray | None = None,
                   frame: int | None = None) -> EpipolarPanel | None:
    """The same frame of a with b's epipolar lines at a wrong and at the chosen Δ_ab."""
    a, b = pair.a, pair.b
    tp = bundle.pair(a, b)
    if tp is None or len(tp.index) == 0 or pair.chosen_offset_s is None:
        return None
    chosen = pair.chosen_offset_s
    lo = np.nanmin(pair.offsets_s) if pair.offsets_s.size else chosen - 1
    hi = np.nanmax(pair.offsets_s) if pair.offsets_s.size else chosen + 1
    wrong = chosen + WRONG_SHIFT_S if chosen + WRONG_SHIFT_S <= hi else chosen - WRONG_SHIFT_S
    wrong = float(np.clip(wrong, lo, hi))
    va, vb = bundle.video(a), bundle.video(b)
    ia, ib = tp.index[:, 0], tp.index[:, 1]
    vis_a = np.isfinite(bundle.tracks[a].xy[ia, :, 0])  # (P,Ta)
    vis_b = np.isfinite(bundle.tracks[b].xy[ib, :, 0])
    count = np.zeros(va.num_frames)
    both = vis_a.copy()
    for d in (chosen, wrong):
        k, _ = frame_brackets(vb.timestamps_s, va.timestamps_s - d)
        kc = np.clip(k, 0, vb.num_frames - 2)
        seen = vis_b[:, kc] & vis_b[:, np.minimum(kc + 1, vb.num_frames - 1)] & (k >= 0)[None]
        both &= seen
    count = both.sum(0)
    if frame is None:
        if count.max() == 0:
            return None
        # among the frames with at least 80 % of the best count, the one nearest the middle
        good = np.flatnonzero(count >= 0.8 * count.max())
        frame = int(good[np.argmin(np.abs(good - va.num_frames / 2))])
    sel = np.flatnonzero(both[:, frame])
    show = np.arange(len(sel))
    if len(sel) > MAX_EPIPOLAR_MATCHES:
        show = np.linspace(0, len(sel) - 1, MAX_EPIPOLAR_MATCHES).round().astype(int)
    rows = tp.index[sel]
    states = [_epipolar_state(bundle, a, b, rows, frame, d, show) for d in (wrong, chosen)]
    if image_bgr is not None and image_bgr.shape[:2] != (va.height, va.width):
        log.warning("frame of %s is %s, bundle says %dx%d: drawing on a blank canvas",
                    a, image_bgr.shape[:2], va.width, va.height)
        image_bgr = None
    return EpipolarPanel(a, b, frame, float(va.timestamps_s[frame]), va.width, va.height,
                         states[0], states[1], image_bgr)


# ---- triangulation of moving points after sync --------------------------------------------


def triangulate_pair(bundle: CueBundle, a: str, b: str, offset_a_s: float, offset_b_s: float,
                     max_tracks: int) -> list[Trajectory]:
    """Trajectories of the matched tracks of (a, b), b sampled at a's frames after sync."""
    tp = bundle.pair(a, b)
    if tp is None or len(tp.index) == 0:
        return []
    va, ca = bundle.video(a), bundle.cameras[a]
    rows = tp.index
    if len(rows) > 4 * max_tracks:
        rows = rows[np.linspace(0, len(rows) - 1, 4 * max_tracks).round().astype(int)]
    ta = va.timestamps_s
    xb, K_b, T_b = _sample_b(bundle, b, rows[:, 1], ta + offset_a_s - offset_b_s)  # (P,Ta,2)
    xa = bundle.tracks[a].xy[rows[:, 0]].astype(np.float64)  # (P,Ta,2)
    frames = np.arange(va.num_frames)
    P_a = ca.K_at(frames) @ ca.pose_at(frames)[:, :3, :]  # (Ta,3,4)
    P_b = K_b @ T_b[:, :3, :]
    ok = np.isfinite(xa[..., 0]) & np.isfinite(xb[..., 0]) & np.isfinite(P_b[None, :, 0, 0])
    X = np.full(xa.shape[:2] + (3,), np.nan)
    pi, fi = np.nonzero(ok)
    if len(pi) == 0:
        return []
    Xs = triangulate_dlt(P_a[fi], P_b[fi], xa[pi, fi], xb[pi, fi])
    with np.errstate(invalid="ignore"):
        ra = np.linalg.norm(project(ca.K_at(fi), ca.pose_at(fi), Xs) - xa[pi, fi], axis=-1)
        rb = np.linalg.norm(project(K_b[fi], T_b[fi], Xs) - xb[pi, fi], axis=-1)
    # the angle between the two viewing rays: near-parallel rays fix no depth
    u, v = Xs - camera_centers(ca.pose_at(fi)), Xs - camera_centers(T_b[fi])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("ni,ni->n", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    angle_deg = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    good = (ra < MAX_REPROJ_PX) & (rb < MAX_REPROJ_PX) & (angle_deg > MIN_RAY_ANGLE_DEG)
    X[pi[good], fi[good]] = Xs[good]
    out = []
    g = ta + offset_a_s
    for p in range(len(rows)):
        for seg in _segments(X[p]):
            out.append(Trajectory(X[p, seg], g[seg], (a, b)))
    return out


def _segments(X: np.ndarray, min_len: int = 5) -> list[np.ndarray]:
    """Runs of consecutive finite samples of (T,3), split where one step jumps more than 8 x the
    median step (a wrong match or a near-parallel pair of rays); runs shorter than min_len dropped."""
    ok = np.isfinite(X[:, 0])
    idx = np.flatnonzero(ok)
    if len(idx) < min_len:
        return []
    step = np.linalg.norm(np.diff(X[idx], axis=0), axis=1)
    med = np.median(step) if len(step) else 0.0
    cut = (np.diff(idx) > 1) | (step > 8.0 * med + 1e-12)
    runs = np.split(idx, np.flatnonzero(cut) + 1)
    return [r for r in runs if len(r) >= min_len]


def trajectories(bundle: CueBundle, pairs: tuple[PairView, ...], offsets_s: dict[str, float | None],
                 cameras: tuple[CameraView, ...]) -> tuple[Trajectory, ...]:
    """Triangulate the best accepted pairs; drop far-away points (wrong matches, near-parallel rays)."""
    ok = [p for p in pairs if p.accepted and offsets_s.get(p.a) is not None
          and offsets_s.get(p.b) is not None]
    ok.sort(key=lambda p: (-p.contrast, p.key))
    per = max(1, MAX_TRAJECTORIES // max(1, min(TRAJ_PAIRS, len(ok))))
    out: list[Trajectory] = []
    for p in ok[:TRAJ_PAIRS]:
        out += triangulate_pair(bundle, p.a, p.b, offsets_s[p.a], offsets_s[p.b], per)[:per]
    if not out:
        return ()
    # keep what lies inside the region the cameras look at: within 1.5 x the cameras' radius
    centers = np.concatenate([c.centers() for c in cameras]) if cameras else np.zeros((1, 3))
    allpts = np.concatenate([t.points_world for t in out])
    mid = np.median(allpts, axis=0)
    radius = 1.5 * np.max(np.linalg.norm(centers - centers.mean(0), axis=1)) if len(centers) > 1 else \
        5.0 * np.median(np.linalg.norm(allpts - mid, axis=1))
    kept = []
    for t in out:
        m = np.linalg.norm(t.points_world - mid, axis=1) < radius
        if m.sum() >= 5:
            kept.append(Trajectory(t.points_world[m], t.time_s[m], t.pair))
    return tuple(kept)


def mosaic_moment(bundle: CueBundle, offsets_s: dict[str, float | None]) -> tuple[float, dict[str, int | None]]:
    """A global moment seen by as many synchronized videos as possible (the middle of the common
    span), and each video's nearest frame there (None: not covered or unresolved)."""
    spans = {v.name: (v.timestamps_s[0] + offsets_s[v.name], v.timestamps_s[-1] + offsets_s[v.name])
             for v in bundle.videos if offsets_s.get(v.name) is not None}
    if not spans:
        return float("nan"), {v.name: None for v in bundle.videos}
    lo, hi = max(s[0] for s in spans.values()), min(s[1] for s in spans.values())
    if hi < lo:  # no moment common to all: the one covered by most videos
        grid = np.linspace(min(s[0] for s in spans.values()), max(s[1] for s in spans.values()), 400)
        cover = sum(((grid >= a) & (grid <= b)).astype(int) for a, b in spans.values())
        best = grid[cover == cover.max()]
        g = float(np.median(best))
    else:
        g = 0.5 * (lo + hi)
    frames: dict[str, int | None] = {}
    for v in bundle.videos:
        off = offsets_s.get(v.name)
        if off is None or not (spans[v.name][0] <= g <= spans[v.name][1]):
            frames[v.name] = None
            continue
        frames[v.name] = int(np.argmin(np.abs(v.timestamps_s + off - g)))
    return g, frames


def _downscale(img: np.ndarray, max_width: int = 480) -> np.ndarray:
    import cv2
    h, w = img.shape[:2]
    if w <= max_width:
        return img
    return cv2.resize(img, (max_width, int(round(h * max_width / w))), interpolation=cv2.INTER_AREA)


def build_report_data(result: RunResult, bundle: CueBundle | None, *, source: str,
                      gt: dict[str, float] | None = None, video_paths: dict[str, str] | None = None,
                      pair: tuple[str, str] | None = None, frame_reader=None,
                      static_points: np.ndarray | None = None,
                      static_colors: np.ndarray | None = None) -> ReportData:
    """ReportData from a run's result and (when available) the cue bundle behind it.

    frame_reader(path, frame_index) -> (H,W,3) uint8 BGR or None reads video a's frame for the
    epipolar panel when a video path is known.
    """
    notes: list[str] = []
    if gt is None:
        gt = result.gt_offsets_s or (bundle.gt_offsets_s if bundle is not None else None)
    pairs = pair_views(result, gt)
    offsets = {k: (None if v is None else float(v)) for k, v in result.offsets_s.items()}
    unc = {k: (None if v is None else float(v)) for k, v in result.uncertainty_s.items()}
    videos: tuple[VideoClock, ...] = ()
    cameras: tuple[CameraView, ...] = ()
    trajs: tuple[Trajectory, ...] = ()
    panel = None
    if bundle is None:
        notes.append("no cue bundle: no timeline, 3D scene or epipolar panel (only landscapes, "
                     "pair graph and numbers)")
    else:
        videos = video_clocks(bundle, video_paths)
        cameras = camera_views(bundle)
        trajs = trajectories(bundle, pairs, offsets, cameras)
        if not trajs:
            notes.append("no triangulated trajectories (no accepted pair with solved offsets "
                         "gave consistent points)")
        chosen = choose_pair(pairs, pair)
        if chosen is None:
            notes.append("epipolar panel: no pair has a minimum")
        else:
            image = None
            path = (video_paths or {}).get(chosen.a)
            panel = epipolar_panel(bundle, chosen)
            if panel is not None and path and frame_reader is not None:
                try:
                    image = frame_reader(path, panel.frame_a)
                except Exception as exc:  # a missing or unreadable video only loses the backdrop
                    notes.append(f"could not read frame {panel.frame_a} of {path}: {exc}")
                if image is not None:
                    panel = epipolar_panel(bundle, chosen, image, panel.frame_a)
            if panel is None:
                notes.append(f"epipolar panel: pair {chosen.key} has no matched points visible "
                             "at both offsets")
    mosaic = None
    if bundle is not None and video_paths and frame_reader is not None:
        g, frames = mosaic_moment(bundle, offsets)
        tiles = []
        for v in bundle.videos:
            k, img = frames[v.name], None
            if k is not None and v.name in video_paths:
                try:
                    img = frame_reader(video_paths[v.name], k, exact=False)
                    img = _downscale(img) if img is not None else None
                except Exception as exc:
                    notes.append(f"mosaic: could not read frame {k} of {video_paths[v.name]}: {exc}")
            tiles.append(MosaicTile(v.name, k, img))
        if any(t.image_bgr is not None for t in tiles):
            mosaic = Mosaic(g, tuple(tiles))
    if mosaic is None:
        notes.append("no mosaic of one moment across all videos: no video frames (result.json "
                     "lists no readable input.videos, or the recording carries no frames)")
    if static_points is None:
        notes.append("no static reconstruction in the input (cue bundles carry cameras and "
                     "tracks only)")
    return ReportData(source, result.reference, videos, offsets, unc, dict(result.unresolved), pairs,
                      gt, cameras, static_points, static_colors, trajs, panel, mosaic, tuple(notes),
                      {k: float(v) for k, v in result.timings_s.items()})


# ---- the report's data of a run folder or of a recording alone ------------------------------


def _frame_reader(path: str, index: int, exact: bool = True) -> np.ndarray | None:
    from ..io.video import open_video, read_frames
    return read_frames(open_video(path), [index])[0]


def _video_paths(result: RunResult, base: Path) -> dict[str, str]:
    """{video name: existing file} of the run's input videos (as given, or relative to base)."""
    out = {}
    for name, p in result.inputs.videos.items():
        if not p:
            continue
        for cand in (Path(str(p)), base / str(p)):
            if cand.exists():
                out[str(name)] = str(cand)
                break
    return out


def find_bundle(run_dir: Path, result: RunResult) -> Path | None:
    """The run's input bundle (as given, or relative to the run folder), else OUT/cues, OUT/bundle."""
    cands = []
    if result.inputs.bundle:
        cands += [Path(result.inputs.bundle), run_dir / result.inputs.bundle]
    cands += [run_dir / "cues", run_dir / "bundle"]
    for c in cands:
        if (c / "bundle.json").is_file():
            return c
    return None


def report_data_from_run(run_dir: str | os.PathLike, pair: tuple[str, str] | None = None) -> ReportData:
    """ReportData of a run folder (OUT/result.json and the cue bundle it names)."""
    from ..io.bundle import read_bundle, read_gt
    from ..io.result import read_run_result

    run_dir = Path(run_dir)
    result = read_run_result(run_dir)
    bdir = find_bundle(run_dir, result)
    bundle = read_bundle(bdir) if bdir is not None else None
    if bdir is None:
        log.warning("%s: no cue bundle found (input.bundle, cues/, bundle/)", run_dir)
    gt = result.gt_offsets_s
    if gt is None and bdir is not None and (bdir / "gt.json").is_file():
        gt = read_gt(bdir / "gt.json")
    return build_report_data(result, bundle, source=str(run_dir), gt=gt,
                             video_paths=_video_paths(result, run_dir), pair=pair,
                             frame_reader=_frame_reader)


def report_data_from_recording(path: str | os.PathLike,
                               pair: tuple[str, str] | None = None) -> ReportData:
    """ReportData from a recording alone (no run folder, no videos, no recompute): its result,
    its embedded cue bundle and the frames it carries."""
    from ..io.recording import META_BUNDLE, META_RESULT, read_recorded_bundle, read_recording, read_rrd_frames

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file")
    rec = read_recording(path, with_structure=False, bundle=True)
    if rec.result is None:
        raise InputError(f"{path}: the recording has no {META_RESULT} (was it written by "
                         "vs-inspect's RerunSink after the sync finished?)")
    bundle = read_recorded_bundle(rec)
    if bundle is None:
        log.warning("%s: no %s in the recording: 3D scene, timeline and epipolar panel are missing",
                    path, META_BUNDLE)
    frames = None
    if bundle is not None:
        try:
            frames = read_rrd_frames(path, [(v.name, v.width, v.height) for v in bundle.videos])
        except Exception as exc:  # frames are a backdrop: without them the figures still work
            log.warning("%s: could not read video frames (%s)", path, exc)
    reader = None
    video_paths = None
    if frames is not None and frames.names():
        video_paths = {n: f"rrd:{n}" for n in frames.names()}

        def reader(p: str, index: int, exact: bool = True):
            return frames.read(p[4:], index, exact)
    data = build_report_data(rec.result, bundle, source=str(path), gt=rec.result.gt_offsets_s,
                             pair=pair, video_paths=video_paths, frame_reader=reader)
    if bundle is None:
        data = replace(data, notes=data.notes + (f"the recording has no {META_BUNDLE}",))
    return data


def load_report_data(path: str | os.PathLike, pair: tuple[str, str] | None = None) -> ReportData:
    """ReportData of a run folder, a result.json, or an .rrd recording."""
    p = Path(path)
    if p.is_dir():
        return report_data_from_run(p, pair)
    if p.suffix == ".rrd":
        return report_data_from_recording(p, pair)
    if p.name.endswith(".json") and p.is_file():
        return report_data_from_run(p.parent, pair)
    if not p.exists():
        raise InputError(f"{p}: no such run folder or recording")
    raise InputError(f"{p}: give a run folder (with result.json) or a .rrd recording")
