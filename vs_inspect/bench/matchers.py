"""Feature matchers measured on the real data: SIFT, XFeat (+ mutual nearest neighbours or
LighterGlue), ALIKED + LightGlue and DISK + LightGlue.

Pairs: views of one scene at the same true moment (caliscope: the same sync_index; VisualSync
clips: the same frame of the common timeline, clip frame = timeline frame - its start number).
For every pair and method:
- background: matches with both ends outside the (dilated) moving regions, and the share within
  2 px (Sampson distance) of the reference epipolar geometry; caliscope also the relative
  rotation from those matches (essential matrix, calibrated K) against the calibration's;
- moving: the keypoints inside the moving regions of both views matched on their own (as the
  pipeline's keyframe matching does), and the share within 2 px of the reference geometry;
- seconds: features of both images plus matching (nothing cached).

Reference geometry: caliscope, its calibration ("true"); the clips have none, so it is estimated:
MAGSAC (1 px) on the pooled full-frame matches of every method at that pair ("estimated").
The cameras of sfm_table come from estimate_cameras (the pipeline's SfM) with each feature kind.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..geometry.epipolar import fundamental_from_cameras, relative_pose
from ..geometry.two_view import essential_ransac, fundamental_ransac, pose_from_essential, sampson_px
from ..io.calibration import undistort_points
from ..types import CameraCalibration

METHODS = ("sift", "xfeat-mnn", "aliked-lightglue")
MAX_SIDE = 1024  # images are downscaled to at most this side before features
TOP_K = 2048  # keypoints per image
SAMPSON_PX = 2.0  # a match within this of the reference epipolar geometry counts as consistent


@dataclass(frozen=True)
class View:
    name: str
    image: np.ndarray  # (H,W,3) uint8 BGR at bench resolution
    moving: np.ndarray  # (H,W) bool, dilated moving regions
    K: np.ndarray | None  # (3,3) px at bench resolution (caliscope), else None
    dist: np.ndarray | None  # OpenCV distortion (caliscope), else None
    cam_from_world: np.ndarray | None  # (4,4) (caliscope), else None


@dataclass(frozen=True)
class PairRow:
    dataset: str
    pair: str  # "a|b@moment"
    method: str
    bg_matches: int  # full-frame matches with both ends outside the moving regions
    bg_consistent: float  # share of those within SAMPSON_PX of the reference geometry
    rot_err_deg: float | None  # relative rotation from the background matches vs calibration
    mov_matches: int  # matches among the keypoints inside the moving regions
    mov_consistent: float  # share of those within SAMPSON_PX
    seconds: float  # features of both images + full-frame matching
    reference: str  # "true" (calibration) or "estimated" (pooled MAGSAC)


class _Sift:
    """The pipeline's keyframe matcher: its RootSIFT detector, ratio 0.8 + mutual check."""

    def __init__(self, top_k: int):
        from ..cues.pairing.descriptors import sift_detector

        self._detect = sift_detector(top_k)

    def features(self, img, mask=None):
        from ..cues.features.learned import Features

        xy, d = self._detect(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY),
                             None if mask is None else mask.astype(np.uint8) * 255)
        return Features(xy, d, (img.shape[1], img.shape[0]))

    def match(self, a, b):
        from ..cues.pairing.descriptors import match_descriptors

        return match_descriptors(a.descriptors, b.descriptors, 0.8, True).astype(np.uint32)


def make_bench_matcher(method: str, top_k: int = TOP_K):
    from ..cues.features.learned import LightGlueMatcher, XFeatMatcher

    if method == "sift":
        return _Sift(top_k)
    if method.startswith("xfeat"):
        return XFeatMatcher(top_k=top_k)
    return LightGlueMatcher(method.split("-")[0], top_k=top_k)


def _subset(f, keep: np.ndarray):
    return dataclasses.replace(f, keypoints=f.keypoints[keep], descriptors=f.descriptors[keep])


def _inside(mask: np.ndarray, xy: np.ndarray) -> np.ndarray:
    h, w = mask.shape
    xi = np.clip(np.round(xy[:, 0]).astype(int), 0, w - 1)
    yi = np.clip(np.round(xy[:, 1]).astype(int), 0, h - 1)
    return mask[yi, xi]


def _undistort(v: View, xy: np.ndarray) -> np.ndarray:
    """(M,2) px undistorted as the pipeline does (io.calibration.undistort_points: run to
    convergence; NaN outside the lens model's valid region)."""
    if v.K is None or not len(xy):
        return xy.astype(np.float64)
    return undistort_points(CameraCalibration(v.K, v.dist, v.cam_from_world, None), xy)


def _sampson_px(F, xa, xb) -> np.ndarray:
    """Sampson distance (px) of each match; inf without an F."""
    if F is None or not len(xa):
        return np.full(len(xa), np.inf)
    return sampson_px(F, xa, xb)


def _rotation_error_deg(va: View, vb: View, xa: np.ndarray, xb: np.ndarray) -> float | None:
    """Relative rotation b->a from matches (essential matrix in normalized coordinates) vs calibration."""
    if va.K is None or len(xa) < 8:
        return None

    def normalized(v: View, xy: np.ndarray) -> np.ndarray:
        u = _undistort(v, xy)
        return (np.c_[u, np.ones(len(u))] @ np.linalg.inv(v.K).T)[:, :2]

    na, nb = normalized(va, xa), normalized(vb, xb)
    ok = np.isfinite(na).all(1) & np.isfinite(nb).all(1)
    if ok.sum() < 8:
        return None
    na, nb = na[ok], nb[ok]
    thr = 1.0 / va.K[0, 0]
    E_ba, inl = essential_ransac(nb, na, thr, 0.9999)
    if E_ba is None:
        return None
    R = pose_from_essential(E_ba, nb, na, inl)[:3, :3]  # a_from_b: x_a = R x_b + t
    R_true = relative_pose(va.cam_from_world, vb.cam_from_world)[:3, :3]
    c = (np.trace(R.T @ R_true) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))))


def measure_pair(dataset: str, label: str, va: View, vb: View, matchers: dict) -> list[PairRow]:
    """One row per method for the views va, vb (same true moment)."""
    got = {}
    for method, m in matchers.items():
        t0 = time.perf_counter()
        fa, fb = m.features(va.image), m.features(vb.image)
        idx = m.match(fa, fb)
        sec = time.perf_counter() - t0
        ia, ib = _inside(va.moving, fa.keypoints), _inside(vb.moving, fb.keypoints)
        # moving regions matched on their own keypoints only (the pipeline's dynamic_only matching)
        sa, sb = np.nonzero(ia)[0], np.nonzero(ib)[0]
        mi = m.match(_subset(fa, sa), _subset(fb, sb))
        got[method] = (fa, fb, idx, ia, ib, sa[mi[:, 0]] if len(mi) else sa[:0], sb[mi[:, 1]] if len(mi) else sb[:0], sec)
    if va.K is not None:
        F = fundamental_from_cameras(va.K, va.cam_from_world, vb.K, vb.cam_from_world)
        reference = "true"
    else:
        pa = np.concatenate([g[0].keypoints[g[2][:, 0]] for g in got.values()])
        pb = np.concatenate([g[1].keypoints[g[2][:, 1]] for g in got.values()])
        F = None
        if len(pa) >= 8:
            F_ba, _ = fundamental_ransac(pb, pa, 1.0, 0.9999, 10000)
            F = None if F_ba is None else F_ba.T  # x_aᵀ F x_b = 0
        reference = "estimated"
    rows = []
    for method, (fa, fb, idx, ia, ib, ma, mb, sec) in got.items():
        bg = ~ia[idx[:, 0]] & ~ib[idx[:, 1]] if len(idx) else np.zeros(0, bool)
        xa, xb = fa.keypoints[idx[bg, 0]], fb.keypoints[idx[bg, 1]]
        ua, ub = _undistort(va, xa), _undistort(vb, xb)
        bg_ok = _sampson_px(F, ua, ub) < SAMPSON_PX
        mxa, mxb = _undistort(va, fa.keypoints[ma]), _undistort(vb, fb.keypoints[mb])
        mov_ok = _sampson_px(F, mxa, mxb) < SAMPSON_PX
        rows.append(PairRow(dataset, label, method, int(bg.sum()), float(bg_ok.mean()) if len(bg_ok) else 0.0,
                            _rotation_error_deg(va, vb, xa, xb), len(ma),
                            float(mov_ok.mean()) if len(mov_ok) else 0.0, sec, reference))
    return rows


# ---- the data ----------------------------------------------------------------------------------


def _moving_masks(path: Path, frames: list[int], size: tuple[int, int]) -> dict[int, np.ndarray]:
    """Dilated moving regions (the pipeline's motion step at its working resolution) of `frames`,
    resized to size (width, height)."""
    from ..cues.config import CueConfig
    from ..cues.video.motion import moving_regions
    from ..io.video import iter_frames, open_video

    cfg = CueConfig()
    src = open_video(path)
    grey = np.stack([cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) for _, img in iter_frames(src, max_side=cfg.max_side)])
    inst, _, _ = moving_regions(grey, frame_interval_s=src.info.frame_interval_s)
    out = {}
    for k in frames:
        m = cv2.resize((inst[k] > 0).astype(np.uint8), size, interpolation=cv2.INTER_NEAREST)
        out[k] = cv2.dilate(m, np.ones((15, 15), np.uint8)) > 0
    return out


def _read(path: Path, frames: list[int]) -> dict[int, np.ndarray]:
    from ..io.video import open_video, read_frames

    return dict(zip(frames, read_frames(open_video(path), frames, max_side=MAX_SIDE)))


def clip_views(root: Path, scene: str, moments: int = 1) -> list[tuple[str, list[View]]]:
    """[(moment label, views)] of one VisualSync scene at `moments` common timeline frames."""
    from .videos import CLIP_FPS, clip_truth

    paths = sorted((root / scene).glob("*.mp4"))
    start = {p: round(t * CLIP_FPS) for p, t in zip(paths, clip_truth(paths).values())}
    from ..io.video import open_video
    n = {p: open_video(p).info.num_frames for p in paths}
    lo, hi = max(start.values()), min(start[p] + n[p] - 1 for p in paths)
    ts = np.linspace(lo, hi, moments + 2)[1:-1].round().astype(int).tolist()
    per = {}
    for p in paths:
        ks = [t - start[p] for t in ts]
        imgs = _read(p, ks)
        h, w = imgs[ks[0]].shape[:2]
        masks = _moving_masks(p, ks, (w, h))
        per[p] = {t: (imgs[k], masks[k]) for t, k in zip(ts, ks)}
    name = {p: p.stem.split("_")[-4] for p in paths}
    return [(f"t{t}", [View(name[p], *per[p][t], None, None, None) for p in paths]) for t in ts]


def caliscope_views(root: Path, moments: int = 2) -> list[tuple[str, list[View]]]:
    import tomllib

    from .datasets import read_caliscope_timestamps

    stamps = read_caliscope_timestamps(root)
    common = sorted(set.intersection(*(set(si.tolist()) for si, _ in stamps.values())))
    sis = [common[int(i)] for i in np.linspace(0, len(common) - 1, moments + 2)[1:-1].round()]
    arr = tomllib.loads((root / "camera_array.toml").read_text())["cameras"]
    per = {}
    for c, (si_all, _) in stamps.items():
        p = root / "calibration" / "extrinsic" / f"cam_{c}.mp4"
        ks = [int(np.nonzero(si_all == si)[0][0]) for si in sis]
        imgs = _read(p, ks)
        h, w = imgs[ks[0]].shape[:2]
        masks = _moving_masks(p, ks, (w, h))
        spec = arr[str(c)]
        s = w / spec["size"][0]
        K = np.array(spec["matrix"], float)
        K[:2] *= s
        K[0, 2], K[1, 2] = (spec["matrix"][0][2] + 0.5) * s - 0.5, (spec["matrix"][1][2] + 0.5) * s - 0.5
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = np.array(spec["rotation"], float), np.array(spec["translation"], float)
        per[c] = (ks, imgs, masks, K, np.array(spec["distortions"], float), T)
    out = []
    for j, si in enumerate(sis):
        views = [View(f"cam_{c}", v[1][v[0][j]], v[2][v[0][j]], v[3], v[4], v[5]) for c, v in per.items()]
        out.append((f"s{si}", views))
    return out


def pair_table(data: Path, datasets: list[str], methods: tuple[str, ...] = METHODS,
               clip_moments: int = 1, caliscope_moments: int = 2, log=print) -> list[PairRow]:
    """Every method on every view pair of every dataset (see the module docstring)."""
    import itertools

    import torch

    torch.manual_seed(0)
    matchers = {m: make_bench_matcher(m) for m in methods}
    rows: list[PairRow] = []
    for ds in datasets:
        if ds == "caliscope":
            moments = caliscope_views(data / "caliscope_post_optimization", caliscope_moments)
        else:
            moments = clip_views(data / "visualsync_clips", ds, clip_moments)
        for label, views in moments:
            for va, vb in itertools.combinations(views, 2):
                for r in measure_pair(ds, f"{va.name}|{vb.name}@{label}", va, vb, matchers):
                    rows.append(r)
                    log(format_row(r))
    return rows


def format_row(r: PairRow) -> str:
    rot = f"{r.rot_err_deg:6.2f}" if r.rot_err_deg is not None else "     -"
    return (f"{r.dataset:11s} {r.pair:28s} {r.method:18s} bg {r.bg_matches:5d} {100 * r.bg_consistent:5.1f}% "
            f"rot {rot}  mov {r.mov_matches:4d} {100 * r.mov_consistent:5.1f}%  {r.seconds:6.2f} s ({r.reference})")


def summary_table(rows: list[PairRow]) -> str:
    """Markdown: per dataset and method, medians over pairs (matches, consistent shares, seconds)."""
    lines = [("| data | method | pairs | bg matches | bg within 2 px | rot err (deg) | moving matches | "
              "moving within 2 px | moving consistent matches | s / pair |"),
             "|---|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r.dataset, r.method) for r in rows}, key=lambda k: (k[0], METHODS.index(k[1])))
    for ds, m in keys:
        sel = [r for r in rows if r.dataset == ds and r.method == m]
        rot = [r.rot_err_deg for r in sel if r.rot_err_deg is not None]
        lines.append(
            f"| {ds} ({sel[0].reference}) | {m} | {len(sel)} | {np.median([r.bg_matches for r in sel]):.0f} | "
            f"{100 * np.median([r.bg_consistent for r in sel]):.0f} % | "
            f"{(f'{np.median(rot):.2f}' if rot else '-')} | {np.median([r.mov_matches for r in sel]):.0f} | "
            f"{100 * np.median([r.mov_consistent for r in sel]):.0f} % | "
            f"{np.median([r.mov_matches * r.mov_consistent for r in sel]):.0f} | "
            f"{np.median([r.seconds for r in sel]):.2f} |")
    return "\n".join(lines)


# ---- camera estimation (the pipeline's SfM) -------------------------------------------------------


@dataclass(frozen=True)
class SfmRow:
    dataset: str
    features: str  # sift, xfeat (mutual nearest neighbours), aliked
    xfeat_matcher: str
    images: int
    cameras: int  # videos registered (and trusted: enough 3D points)
    videos: int
    fewest_points: int  # 3D points seen by the weakest registered camera's best image
    rot_err_deg: float | None  # median relative-rotation error over registered camera pairs (calibration)
    seconds: float


def sfm_inputs(paths: list[Path], static_frames: int = 9, moving_frames: int = 30, max_side: int = 1280):
    """The pipeline's SfM input per video (video_cues._video_cues): frames with the moving regions
    masked, one temporal-median image for a static camera. -> (frames_by_video, sizes, num_frames, moving)."""
    from ..cues.config import CueConfig
    from ..cues.video.motion import moving_regions
    from ..io.video import iter_frames, open_video, read_frames

    cfg = CueConfig()
    frames, sizes, nframes, moving = {}, {}, {}, {}
    for p in paths:
        src = open_video(p)
        grey = np.stack([cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) for _, img in iter_frames(src, max_side=cfg.max_side)])
        inst, mode, _ = moving_regions(grey, frame_interval_s=src.info.frame_interval_s)
        n = moving_frames if mode == "moving" else static_frames
        idx = np.unique(np.linspace(0, len(grey) - 1, max(1, min(n, len(grey)))).round().astype(int))
        imgs = read_frames(src, idx, max_side=max_side)
        masks = []
        for k, im in zip(idx, imgs):
            m = cv2.resize((inst[k] > 0).astype(np.uint8), (im.shape[1], im.shape[0]), interpolation=cv2.INTER_NEAREST)
            masks.append(cv2.dilate(m, np.ones((15, 15), np.uint8)) == 0)
        if mode == "static" and len(imgs) > 1:
            imgs = [np.median(np.stack(imgs), axis=0).astype(np.uint8)]
            masks = [np.mean([~m for m in masks], axis=0) < 0.5]
            idx = idx[:1]
        name = p.stem
        frames[name] = (idx, imgs, masks)
        sizes[name] = (src.info.width, src.info.height)
        nframes[name] = src.info.num_frames
        moving[name] = mode == "moving"
    return frames, sizes, nframes, moving


def sfm_table(data: Path, datasets: list[str], kinds: tuple[tuple[str, str], ...], moving_frames: int = 30,
              log=print) -> list[SfmRow]:
    """estimate_cameras with each (features, xfeat_matcher) on each dataset."""
    import itertools

    from ..cues.cameras.sfm import estimate_cameras
    from ..cues.config import CameraConfig

    rows = []
    for ds in datasets:
        truth = None
        if ds == "caliscope":
            root = data / "caliscope_post_optimization"
            paths = sorted((root / "calibration" / "extrinsic").glob("cam_*.mp4"))
            from .datasets import load_caliscope
            truth = load_caliscope(root).cameras
        else:
            paths = sorted((data / "visualsync_clips" / ds).glob("*.mp4"))
        inputs = sfm_inputs(paths, moving_frames=moving_frames)
        for feats, xm in kinds:
            t0 = time.perf_counter()
            est = estimate_cameras(*inputs, CameraConfig(features=feats))
            sec = time.perf_counter() - t0
            rot = None
            if truth is not None and len(est.cameras) >= 2:
                errs = []
                for a, b in itertools.combinations(sorted(est.cameras), 2):
                    Ta, Tb = est.cameras[a].track.cam_from_world, est.cameras[b].track.cam_from_world
                    R = relative_pose(Ta, Tb)[:3, :3]
                    Rt = relative_pose(truth[a].cam_from_world, truth[b].cam_from_world)[:3, :3]
                    errs.append(np.degrees(np.arccos(np.clip((np.trace(R.T @ Rt) - 1) / 2, -1, 1))))
                rot = float(np.median(errs))
            r = SfmRow(ds, feats, xm, est.num_images, len(est.cameras), len(paths),
                       min((c.points_seen for c in est.cameras.values()), default=0), rot, sec)
            rows.append(r)
            log(f"sfm {ds:11s} {feats:6s} {xm:11s} images {r.images:3d} cameras {r.cameras}/{r.videos} "
                f"fewest points {r.fewest_points:5d} rot {rot if rot is None else round(rot, 2)} {sec:7.1f} s")
    return rows


def sfm_markdown(rows: list[SfmRow]) -> str:
    lines = [("| data | features | SfM images | cameras registered | fewest 3D points per camera | "
              "median rotation error (deg) | seconds |"), "|---|---|---|---|---|---|---|"]
    for r in rows:
        name = r.features + (f" + {r.xfeat_matcher}" if r.features == "xfeat" else
                             " + LightGlue" if r.features in ("aliked", "disk") else " (COLMAP)")
        lines.append(f"| {r.dataset} | {name} | {r.images} | {r.cameras}/{r.videos} | {r.fewest_points} | "
                     f"{'-' if r.rot_err_deg is None else f'{r.rot_err_deg:.2f}'} | {r.seconds:.0f} |")
    return "\n".join(lines)


SFM_KINDS = (("sift", "mnn"), ("xfeat", "mnn"), ("aliked", "mnn"))


def main(argv: list[str] | None = None) -> int:
    import argparse
    import json

    p = argparse.ArgumentParser(prog="python -m vs_inspect.bench.matchers", description=__doc__.split("\n")[0])
    p.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2].parent / "shared" / "data")
    p.add_argument("--datasets", nargs="+", default=["caliscope", "blenderbox", "pan160906", "sequence69", "fencing1"])
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    p.add_argument("--sfm", action="store_true", help="camera estimation (estimate_cameras) instead of view pairs")
    p.add_argument("--moving-frames", type=int, default=30, help="--sfm: frames per moving camera")
    p.add_argument("--json", type=Path, default=None, help="write every row here")
    a = p.parse_args(argv)
    if a.sfm:
        kinds = tuple(k for k in SFM_KINDS if {"sift": "sift", "xfeat": f"xfeat-{k[1]}"}.get(
            k[0], f"{k[0]}-lightglue") in a.methods)
        rows = sfm_table(a.data, a.datasets, kinds, a.moving_frames)
        print(sfm_markdown(rows))
    else:
        rows = pair_table(a.data, a.datasets, tuple(a.methods))
        print(summary_table(rows))
    if a.json:
        from ..io.atomic import write_text_atomic

        write_text_atomic(json.dumps([dataclasses.asdict(r) for r in rows], indent=1), a.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
