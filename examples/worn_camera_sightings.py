"""Evidence: a head-worn camera seen by another camera times the pair (geometry/sightings.py).

On fencing1 (three Aria glasses) vs_inspect estimates every camera per frame (0.09-0.15 deg) but
finds no offset: its moving regions miss the fencers. This script asks another question: when
camera b's wearer is in camera a's view, a sees b's head where b's camera centre projects at the
right Δ. It reads a finished `vs-inspect sync --out RUN` (cameras, and result.json's estimated
lens to undistort the detections with) and the body landmarks of examples/detect_heads.py, and
prints, per ordered pair (a sees b's wearer), the candidate Δ with the most head detections
within --radius-px of b's projected centre, its rival farther than --exclude-frames away, the
median distance, and the error against the truth of VisualSync clip names.

    vs-inspect sync ../shared/data/visualsync_clips/fencing1/*.mp4 --out /tmp/f1 --no-rrd
    /tmp/mp/bin/python examples/detect_heads.py ../shared/data/visualsync_clips/fencing1/*.mp4 --out /tmp/f1/heads.npz
    PYTHONPATH=. python examples/worn_camera_sightings.py /tmp/f1 /tmp/f1/heads.npz
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np  # before pycolmap-using modules (ENVIRONMENT.md)

from vs_inspect.bench.videos import clip_truth
from vs_inspect.cues.cameras import undistort_with_lens
from vs_inspect.geometry.sightings import best_sighting, sighting_landscape
from vs_inspect.io.bundle import read_bundle

HEAD_LANDMARKS = list(range(7))  # BlazePose: nose, eyes (inner, centre, outer); glasses sit there


def head_points(landmarks: np.ndarray, min_visibility: float) -> np.ndarray:
    """(T,2) mean of the visible head landmarks of (T,33,3) x, y, visibility (NaN: none visible)."""
    head = landmarks[:, HEAD_LANDMARKS]
    vis = np.nan_to_num(head[..., 2], nan=0.0) >= min_visibility
    with np.errstate(invalid="ignore"):
        return np.where(vis.any(1)[:, None],
                        np.nansum(np.where(vis[..., None], head[..., :2], 0.0), 1) / vis.sum(1)[:, None], np.nan)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, help="output folder of vs-inspect sync (cues/ and result.json)")
    ap.add_argument("heads", type=Path, help="npz of examples/detect_heads.py")
    ap.add_argument("--radius-px", type=float, default=20.0, help="a head this near b's centre counts (px)")
    ap.add_argument("--exclude-frames", type=float, default=3.0, help="a rival peak is farther than this")
    ap.add_argument("--min-visibility", type=float, default=0.5)
    args = ap.parse_args()
    bundle = read_bundle(args.run / "cues")
    sfm = json.loads((args.run / "result.json").read_text())["cues"].get("sfm") or {}
    lens = sfm.get("lens") or {}
    heads = np.load(args.heads)
    infos = {v.name: v for v in bundle.videos}
    names = [n for n in infos if n in bundle.cameras and n in lens and n in heads.files]
    if len(names) < 2:
        print(f"worn_camera_sightings: need two videos with an estimated camera, its lens and heads; got {names}",
              file=sys.stderr)
        return 2
    try:
        truth = clip_truth([Path(n) for n in names])
    except Exception:  # not VisualSync clip names: no truth column
        truth = None
    print(f"{'a sees the wearer of b':58s} {'heads':>5s} {'best Δ s':>9s} {'near':>5s} {'rival':>5s} "
          f"{'median px':>9s} {'true Δ s':>9s} {'error frames':>12s}")
    for a in names:
        ca, va = bundle.cameras[a], infos[a]
        K_a = ca.K if ca.K.ndim == 2 else ca.K[0]
        head = undistort_with_lens(lens[a], K_a, head_points(heads[a], args.min_visibility))
        for b in names:
            if b == a:
                continue
            cb, vb = bundle.cameras[b], infos[b]
            step = 0.5 / max(va.fps, vb.fps)
            grid = np.arange(-va.duration_s - vb.duration_s, va.duration_s + vb.duration_s + step / 2, step)
            valid_a = ca.valid if ca.valid is not None else np.ones(va.num_frames, bool)
            valid_b = cb.valid if cb.valid is not None else np.ones(vb.num_frames, bool)
            land = sighting_landscape(head, va.timestamps_s, K_a, ca.cam_from_world, valid_a, vb.timestamps_s,
                                      cb.cam_from_world, valid_b, grid, args.radius_px)
            best, rival = best_sighting(land, args.exclude_frames / min(va.fps, vb.fps))
            true_d = truth[b] - truth[a] if truth else None
            err = f"{(land.offsets_s[best] - true_d) * min(va.fps, vb.fps):+.1f}" if truth else "-"
            print(f"{a + ' sees ' + b:58s} {int(np.isfinite(head[:, 0]).sum()):5d} {land.offsets_s[best]:+9.2f} "
                  f"{land.near[best]:5d} {rival:5d} {land.median_px[best]:9.1f} "
                  f"{'' if true_d is None else f'{true_d:+9.2f}':>9s} {err:>12s}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
