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

from ..analysis.display_names import display_names
from ..analysis.record_views import over_range
from ..analysis.trajectories import run_trajectories
from ..errors import InputError
from ..geometry.epipolar import (epipolar_lines, epipolar_residual,
                                 fundamental_from_cameras)
from ..geometry.sampling import camera_at_frames, sample_video
from ..result_types import RunResult
from ..types import CueBundle
from ..report.data import (CameraView, EpipolarPanel, EpipolarState, Mosaic, MosaicTile, PairView,
                           ReportData, ThreeViewView, Trajectory, TransferView, VideoClock)

log = logging.getLogger(__name__)

WRONG_SHIFT_S = 0.5  # the "wrong" offset of the epipolar panel is the chosen one ± this
MAX_EPIPOLAR_MATCHES = 16  # matches drawn in the epipolar panel
MAX_TRAJECTORIES = 300  # trajectory segments drawn in the 3D scene
TRAJ_PAIRS = 3  # accepted pairs (best contrast first) triangulated for the 3D scene


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
            float(p.decision.contrast) if math.isfinite(p.decision.contrast) else 0.0,
            None if p.confirm_energy is None else over_range(p.confirm_energy, energy),
            _opt(p.confirm_offset_s), p.residual))
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


# ---- the epipolar panel -------------------------------------------------------------------


def _epipolar_state(bundle: CueBundle, a: str, b: str, rows: np.ndarray, frame: int,
                    offset_s: float, show: np.ndarray) -> EpipolarState:
    va, vb = bundle.video(a), bundle.video(b)
    t_a = float(va.timestamps_s[frame])
    xa = bundle.tracks[a].xy[rows[:, 0], frame].astype(np.float64)  # (P,2)
    at_a = camera_at_frames(bundle.cameras[a], np.array([frame]))
    at_b = sample_video(vb.timestamps_s, bundle.cameras[b], bundle.tracks[b].xy,
                        np.array([t_a - offset_s]), rows=rows[:, 1])
    xb = at_b.xy[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        F = fundamental_from_cameras(at_a.K[0], at_a.cam_from_world[0], at_b.K[0], at_b.cam_from_world[0])
        samp = epipolar_residual(F, xa, xb, "sampson")
    lines = epipolar_lines(F, xb)
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
    valid_a = camera_at_frames(bundle.cameras[a], np.arange(va.num_frames)).valid
    both = np.isfinite(bundle.tracks[a].xy[ia, :, 0]) & valid_a[None]  # (P,Ta)
    for d in (chosen, wrong):  # b's points as the energy reads them at τ_a − Δ
        at_b = sample_video(vb.timestamps_s, bundle.cameras[b], bundle.tracks[b].xy,
                            va.timestamps_s - d, rows=ib)
        both &= np.isfinite(at_b.xy[..., 0])
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
                         states[0], states[1], image_bgr, bool(pair.accepted))


# ---- triangulated trajectories (analysis.trajectories, as the recording shows them) --------


def trajectories(bundle: CueBundle, pairs: tuple[PairView, ...],
                 offsets_s: dict[str, float | None]) -> tuple[Trajectory, ...]:
    """The run's trajectories of the best accepted pairs, one Trajectory per segment, at most
    MAX_TRAJECTORIES in all (4 track pairs triangulated per segment drawn: many are dropped)."""
    accepted = [(p.a, p.b, p.contrast) for p in pairs if p.accepted]
    per = max(1, MAX_TRAJECTORIES // max(1, min(TRAJ_PAIRS, len(accepted))))
    out = []
    for tj in run_trajectories(bundle, accepted, offsets_s, TRAJ_PAIRS, 4 * per):
        out += [Trajectory(tj.points_world[sg.track, sg.start:sg.stop], tj.time_s[sg.start:sg.stop],
                           (tj.a, tj.b)) for sg in tj.segments[:per]]
    return tuple(out)


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


def _camera_checks(result: RunResult, key: str, gt: dict[str, float] | None):
    """(camera, check, origin, true offset or None) of each of Stage 0's per-camera checks (key:
    "transfer" or "three_view") that result.json keeps with its curve."""
    joint = result.cues.geometric_joint if result.cues is not None else None
    if joint is None:
        return
    origin = joint.origin
    for cam, t in (getattr(joint, key) or {}).items():
        if len(t.offsets_s):
            yield cam, t, origin, gt[cam] - gt[origin] if gt and cam in gt and origin in gt else None


def transfer_views(result: RunResult, gt: dict[str, float] | None) -> tuple[TransferView, ...]:
    """Stage 0's point-transfer checks as result.json keeps them (cues.geometric_joint.transfer);
    () when the run made none or has no Stage 0."""
    return tuple(TransferView(cam, np.asarray(t.offsets_s, float), np.asarray(t.share, float), origin,
                              float(t.joint_offset_s), t.transfer_offset_s, truth, bool(t.confirmed), t.reason)
                 for cam, t, origin, truth in _camera_checks(result, "transfer", gt))


def three_view_views(result: RunResult, gt: dict[str, float] | None) -> tuple[ThreeViewView, ...]:
    """Stage 0's three-view checks as result.json keeps them (cues.geometric_joint.three_view);
    () when the run made none."""
    return tuple(ThreeViewView(cam, np.asarray(t.offsets_s, float), np.asarray(t.supporters_by_offset, float),
                               origin, float(t.joint_offset_s), float(t.needed), truth, bool(t.passed), t.reason)
                 for cam, t, origin, truth in _camera_checks(result, "three_view", gt))


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
        trajs = trajectories(bundle, pairs, offsets)
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
    names = [v.name for v in videos] or list(result.offsets_s)
    return ReportData(source, result.reference, videos, offsets, unc, dict(result.unresolved), pairs,
                      gt, cameras, static_points, static_colors, trajs, panel, mosaic,
                      transfer_views(result, gt), tuple(notes),
                      {k: float(v) for k, v in result.timings_s.items()}, three_view_views(result, gt),
                      result.headlines(), display_names(names))


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
    """The run's input bundle (as given, or relative to the run folder), else the rendered
    scene's true bundle (`vs-inspect demo` records the scene, not a bundle: SCENE/bundle, also
    as OUT/scene/bundle when the folder moved), else OUT/cues, OUT/bundle."""
    cands = []
    if result.inputs.bundle:
        cands += [Path(result.inputs.bundle), run_dir / result.inputs.bundle]
    if result.inputs.scene:
        cands += [Path(result.inputs.scene) / "bundle", run_dir / result.inputs.scene / "bundle"]
    cands += [run_dir / "scene" / "bundle", run_dir / "cues", run_dir / "bundle"]
    for c in cands:
        if (c / "bundle.json").is_file():
            return c
    return None


def report_data_from_run(run_dir: str | os.PathLike, pair: tuple[str, str] | None = None,
                         gt: dict[str, float] | None = None) -> ReportData:
    """ReportData of a run folder (OUT/result.json and the cue bundle it names). gt: true
    offsets (else the run's or its bundle's gt.json when there is one)."""
    from ..io.bundle import read_bundle, read_gt
    from ..io.result import read_run_result

    run_dir = Path(run_dir)
    result = read_run_result(run_dir)
    bdir = find_bundle(run_dir, result)
    bundle = read_bundle(bdir) if bdir is not None else None
    if bdir is None:
        log.warning("%s: no cue bundle found (input.bundle, cues/, bundle/)", run_dir)
    gt = gt or result.gt_offsets_s
    if gt is None and bdir is not None and (bdir / "gt.json").is_file():
        gt = read_gt(bdir / "gt.json")
    data = build_report_data(result, bundle, source=str(run_dir), gt=gt,
                             video_paths=_video_paths(result, run_dir), pair=pair,
                             frame_reader=_frame_reader,
                             static_points=bundle.static_points if bundle is not None else None,
                             static_colors=bundle.static_colors if bundle is not None else None)
    if _estimated(result) and (bundle is None or bundle.static_points is None):
        data = replace(data, notes=data.notes + ("the run's cue bundle holds no static reconstruction of its "
                                                 "estimated cameras",))
    return data


def _estimated(result: RunResult) -> bool:
    """Stage 0 estimated the run's cameras (they come with a static reconstruction)."""
    return result.cues is not None and result.cues.camera_source.startswith("estimated")


def report_data_from_recording(path: str | os.PathLike, pair: tuple[str, str] | None = None,
                               gt: dict[str, float] | None = None) -> ReportData:
    """ReportData from a recording alone (no run folder, no videos, no recompute): its result,
    its embedded cue bundle and the frames it carries."""
    from ..io.recorded_frames import read_rrd_frames
    from ..io.recorded_series import read_static_points
    from ..io.recording import read_recorded_bundle, read_recording
    from ..io.recording_paths import META_BUNDLE, META_RESULT

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
    gt = gt or rec.result.gt_offsets_s or (bundle.gt_offsets_s if bundle is not None else None)
    points, colors = read_static_points(path)
    data = build_report_data(rec.result, bundle, source=str(path), gt=gt,
                             pair=pair, video_paths=video_paths, frame_reader=reader,
                             static_points=points if len(points) else None,
                             static_colors=colors if len(points) else None)
    if not len(points) and _estimated(rec.result):
        data = replace(data, notes=data.notes + ("the recording holds no static reconstruction of its "
                                                 "estimated cameras",))
    if bundle is None:
        data = replace(data, notes=data.notes + (f"the recording has no {META_BUNDLE}",))
    return data


def load_report_data(path: str | os.PathLike, pair: tuple[str, str] | None = None,
                     gt: dict[str, float] | None = None) -> ReportData:
    """ReportData of a run folder, a result.json, or an .rrd recording (gt: true offsets)."""
    p = Path(path)
    if p.is_dir():
        return report_data_from_run(p, pair, gt)
    if p.suffix == ".rrd":
        return report_data_from_recording(p, pair, gt)
    if p.name.endswith(".json") and p.is_file():
        return report_data_from_run(p.parent, pair, gt)
    if not p.exists():
        raise InputError(f"{p}: no such run folder or recording")
    raise InputError(f"{p}: give a run folder (with result.json) or a .rrd recording")
