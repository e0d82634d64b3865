"""Benchmark datasets as cue bundles with true offsets.

- Cue-level synthetic scenes (vs_inspect.synth.cues) at three difficulty levels and several seeds.
- The caliscope session (../shared/data/caliscope_post_optimization): REAL detected ChArUco corners
  of 4 synchronized webcams, one track per corner id and camera, exact cross-view pairs by corner
  id, the session's own calibration (points undistorted with it as the pipeline undistorts), per-frame
  timestamps from timestamps.csv (variable-rate bundle). Offsets are made by cutting a different
  number of leading frames from each camera; the true offset is the frame_time of the first kept
  frame.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.calibration import load_calibration, to_camera_track, undistort_points
from ..synth.cues import CueSceneConfig, make_cue_scene
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo

DIFFICULTIES: dict[str, dict] = {
    # noise_px, wrong_fraction, pose_error_deg
    "easy": dict(noise_px=0.3, wrong_fraction=0.10, pose_error_deg=0.1),
    "default": dict(noise_px=0.8, wrong_fraction=0.25, pose_error_deg=0.5),
    "hard": dict(noise_px=1.5, wrong_fraction=0.35, pose_error_deg=1.0),
}
SCENE_CAMERAS = 5  # cameras per synthetic scene (10 pairs: 1 without matches, 1 all wrong)


@dataclass(frozen=True)
class BenchData:
    """One benchmark input: a bundle with true offsets, and optionally the exact cameras."""

    name: str  # e.g. "cue/default/s0" or "caliscope/cut1"
    group: str  # table group, e.g. "cue/default" or "caliscope"
    bundle: CueBundle
    true_cameras: dict[str, CameraTrack] | None = None
    frame_interval_s: float = float("nan")  # typical frame interval, to report errors in frames
    notes: dict = field(default_factory=dict)


def cue_scene(difficulty: str, seed: int, drift_ppm: float = 0.0, seconds: float | None = None) -> BenchData:
    """A synthetic cue scene; drift_ppm: every non-reference video's clock drifts by ± this;
    seconds: the typical video length (default CueSceneConfig's)."""
    if difficulty not in DIFFICULTIES:
        raise InputError(f"unknown difficulty {difficulty!r}; known: {sorted(DIFFICULTIES)}")
    extra = {} if seconds is None else {"seconds": seconds}
    cfg = CueSceneConfig(cameras=SCENE_CAMERAS, seed=seed, drift_ppm=drift_ppm, **DIFFICULTIES[difficulty], **extra)
    scene = make_cue_scene(cfg)
    fi = float(np.median([v.frame_interval_s for v in scene.bundle.videos]))
    return BenchData(f"cue/{difficulty}/s{seed}", f"cue/{difficulty}", scene.bundle,
                     scene.true_cameras, fi,
                     {"all_wrong_pair": scene.all_wrong_pair, "no_match_pairs": scene.no_match_pairs})


# ---- caliscope ------------------------------------------------------------------------------

CALISCOPE = "caliscope_post_optimization"


@dataclass(frozen=True)
class CaliscopeSession:
    """The parsed session: per camera its frame times, corner tracks (distorted px) and camera."""

    names: list[str]
    frame_time_s: dict[str, np.ndarray]  # (T,) absolute seconds, per camera, frame order
    corner_ids: np.ndarray  # (N,) corner (keypoint) ids, the track order of every camera
    xy_px: dict[str, np.ndarray]  # (N,T,2) undistorted px, NaN where not detected
    cameras: dict[str, CameraTrack]
    size: dict[str, tuple[int, int]]  # (width, height)


def read_caliscope_timestamps(root: Path) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """{cam_id: (sync_index (T,), frame_time_s (T,))} in sync order; frame k of cam_N.mp4 is row k."""
    times: dict[int, list[tuple[int, float]]] = {}
    with open(Path(root) / "calibration" / "extrinsic" / "timestamps.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            times.setdefault(int(row["cam_id"]), []).append((int(row["sync_index"]), float(row["frame_time"])))
    out = {}
    for c, v in sorted(times.items()):
        v = sorted(v)
        out[c] = (np.array([si for si, _ in v]), np.array([t for _, t in v]))
    return out


def read_caliscope_frame_times(root: Path) -> dict[str, np.ndarray]:
    """{"cam_N": frame_time_s of each frame of cam_N.mp4, in order}."""
    return {f"cam_{c}": t for c, (_, t) in read_caliscope_timestamps(root).items()}


def load_caliscope(root: Path) -> CaliscopeSession:
    """Read camera_array.toml, timestamps.csv and xy.csv of the session folder."""
    root = Path(root)
    ext = root / "calibration" / "extrinsic"
    for f in (root / "camera_array.toml", ext / "timestamps.csv", ext / "xy.csv"):
        if not f.is_file():
            raise InputError(f"caliscope session incomplete: {f} not found")
    stamps = read_caliscope_timestamps(root)
    cam_ids = sorted(stamps)
    frame_of = {c: {int(si): k for k, si in enumerate(stamps[c][0])} for c in cam_ids}
    rows = []
    with open(ext / "xy.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            rows.append((int(row["cam_id"]), int(row["sync_index"]), int(row["object_id"]),
                         int(row["keypoint_id"]), float(row["img_loc_x"]), float(row["img_loc_y"])))
    # one track per (object id, keypoint id): the same physical corner in every camera
    keys = sorted({(o, k) for _, _, o, k, _, _ in rows})
    kpos = {key: i for i, key in enumerate(keys)}
    names = [f"cam_{c}" for c in cam_ids]
    calib = load_calibration(root / "camera_array.toml", names)
    ft, xy, cams, size = {}, {}, {}, {}
    for c, name in zip(cam_ids, names):
        cams[name] = to_camera_track(calib[name])
        size[name] = calib[name].size
        ft[name] = stamps[c][1]
        raw = np.full((len(keys), len(ft[name]), 2), np.nan)
        for cc, si, o, k, x, y in rows:
            if cc == c and si in frame_of[c]:
                raw[kpos[(o, k)], frame_of[c][si]] = (x, y)
        xy[name] = undistort_points(calib[name], raw)
    return CaliscopeSession(names, ft, np.array([k for _, k in keys]), xy, cams, size)


def caliscope_cut(session: CaliscopeSession, cuts: dict[str, int], name: str) -> BenchData:
    """Bundle of the session with cuts[v] leading frames removed from camera v.

    Local time of v = frame_time - frame_time[first kept frame]; true offset_s[v] = the absolute
    time of v's first kept frame minus that of the reference (the first camera).
    """
    videos, tracks, pairs = [], {}, {}
    first = {}
    for v in session.names:
        c = int(cuts.get(v, 0))
        t = session.frame_time_s[v][c:]
        if len(t) < 10:
            raise InputError(f"cut of {c} frames leaves {len(t)} frames of {v}")
        first[v] = float(t[0])
        w, h = session.size[v]
        videos.append(VideoInfo(v, w, h, len(t), t - t[0], None))
        tracks[v] = Tracks(session.xy_px[v][:, c:].astype(np.float64))
    n = len(session.corner_ids)
    for i, a in enumerate(session.names):
        for b in session.names[i + 1:]:
            both = [j for j in range(n) if np.isfinite(tracks[a].xy[j, :, 0]).any()
                    and np.isfinite(tracks[b].xy[j, :, 0]).any()]
            pairs[(a, b)] = TrackPairs(a, b, np.array([[j, j] for j in both], dtype=np.int64).reshape(-1, 2))
    ref = session.names[0]
    gt = {v: first[v] - first[ref] for v in session.names}
    bundle = CueBundle(tuple(videos), dict(session.cameras), tracks, pairs, gt)
    fi = float(np.median(np.concatenate([np.diff(session.frame_time_s[v]) for v in session.names])))
    return BenchData(name, "caliscope", bundle, None, fi, {"cuts": dict(cuts)})


def caliscope_cuts(session: CaliscopeSession, num: int, max_cut: int = 12, seed: int = 0) -> list[BenchData]:
    """num bundles with random leading cuts in [0, max_cut] frames per camera (seeded; cut set i
    is the same whatever num is)."""
    out = []
    for i in range(num):
        rng = np.random.default_rng([seed, i])
        cuts = {v: int(rng.integers(0, max_cut + 1)) for v in session.names}
        out.append(caliscope_cut(session, cuts, f"caliscope/cut{i}"))
    return out
