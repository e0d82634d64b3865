"""Does the README's time map of cam1 (Mate 7) fit the shipped detections, or does our estimate?

A diagnosis, not part of the pipeline: it uses the README's ground truth, which the pipeline never may.

`vs-inspect bench-drone` puts cameras 2-5 within 0.5 frame and 100 ppm of the README, but cam1
(a variable-frame-rate phone that the dataset's authors remapped to 30 fps) 7 frames and about
-940 ppm off; each of cam1's pairs measures about -900..-1000 ppm on its own. This script asks the
detections directly, window by window, without any rate estimate of ours:

1. per pair (camera c, a well-behaved camera r: cam0, cam2..cam5), c's local times are mapped
   into r's clock by the README (its offset and rate), and one F is fitted over the whole
   recording with that time map held fixed by the package's pose-free estimation
   (sync.posefree.fit_F_at_time_map: MAGSAC, then R, t refined on Sampson distances; the F
   most favourable to the README's map);
2. the recording is cut into windows of --window-s seconds of cam0's (global) clock; in each,
   the local constant shift d (r's seconds) that minimises the truncated Sampson energy
   mean(min(Sampson px, 5 px)^2) of r's detections against c's detections interpolated at
   (README-mapped time - d) is found on a 0.1-frame grid and refined by a parabola;
3. printed: d in c's frames, i.e. the local shift minus the README's prediction (0 if the
   README's map held there), and per pair a line fitted over the windows: its value at the
   recording's middle (frames) and its slope, as a rate error in ppm (1000 ppm = 0.03 frames/s
   at 30 fps = 1.8 frames per minute).

If the README's map of c is right, c's columns stay flat near 0; if c's clock runs at another
rate than the README says, they slide linearly by that rate error in every pair with c, while
pairs without c stay flat. Variable-rate frames that the remapping left in would show as jumps
(the residual of the line, printed per pair, and the finer --fine-window-s windows of c against
cam0). A last table reports how often three consecutive detections are collinear (a sign of
positions linearly interpolated between raw frames, as the authors' remapping does).

    python examples/drone_cam1_evidence.py [--data DIR] [--window-s 60] [--fine-window-s 10]

Reads the dataset from ../shared/data/drone_tracking_dataset3 beside the checkout (or --data).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import theilslopes

from vs_inspect.io.drone import import_drone, read_drone_camera
from vs_inspect.sync.posefree import (
    PoseFreeConfig,
    fit_F_at_time_map,
    interpolate_track,
    sampson_px,
)

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "drone_tracking_dataset3"
REFS = ("cam0", "cam2", "cam3", "cam4", "cam5")  # the cameras whose README maps bench-drone confirms
THRESHOLD_PX = PoseFreeConfig().threshold_px  # the pose-free inlier threshold, here the energy's cap
HALF_RANGE_FRAMES = 30.0  # the shifts searched: the README's ± this many of c's frames
GRID_FRAMES = 0.1
FINE_HALF_FRAMES = 8.0  # the finer windows search their coarse line ± this
MIN_MATCHES = 150  # a window with fewer matched detections gets no shift


@dataclass(frozen=True)
class PairMap:
    """Camera c's detections in r's clock by the README's map, and the F fitted there."""

    r: str
    c: str
    t_r: np.ndarray  # (Tr,) r's local times, s
    g_r: np.ndarray  # (Tr,) the same in the global (cam0) clock by the README
    xy_r: np.ndarray  # (Tr,2) undistorted px, NaN unseen
    t_c_in_r: np.ndarray  # (Tc,) c's local times mapped into r's clock by the README
    xy_c: np.ndarray  # (Tc,2)
    fps_c: float
    F_rc: np.ndarray  # (3,3) x_rᵀ F x_c = 0
    median_px: float  # the whole recording at the README's map: median Sampson px of the inliers
    inlier_share: float  # and the share of matches under 5 px


def pair_map(bundle, gt, r: str, c: str) -> PairMap | None:
    vr, vc = bundle.video(r), bundle.video(c)
    off, d = gt.offsets_s, {k: v * 1e-6 for k, v in gt.drift_ppm.items()}
    t_c_in_r = ((off[c] - off[r]) + (1 + d[c]) * vc.timestamps_s) / (1 + d[r])
    xy_r, xy_c = bundle.tracks[r].xy[0], bundle.tracks[c].xy[0]
    K_r, K_c = bundle.cameras[r].K, bundle.cameras[c].K
    # the README's map held fixed (c's mapped times against r's own): the F most favourable to it
    F, median_px, share = fit_F_at_time_map(vr.timestamps_s, xy_r, K_r, t_c_in_r, xy_c, K_c, 0.0, 1.0)
    if F is None:
        return None
    fps_c = vc.fps or 1.0 / vc.frame_interval_s
    return PairMap(r, c, vr.timestamps_s, off[r] + (1 + d[r]) * vr.timestamps_s, xy_r, t_c_in_r, xy_c,
                   fps_c, F, median_px, share)


def local_shift_frames(pm: PairMap, g0: float, g1: float, centre: float = 0.0,
                       half: float = HALF_RANGE_FRAMES) -> tuple[float, int]:
    """(shift in c's frames minimising the truncated Sampson energy in the window [g0, g1) of
    the global clock, searched over centre ± half, matched detections at that shift); NaN when
    too few."""
    sel = (pm.g_r >= g0) & (pm.g_r < g1) & np.isfinite(pm.xy_r).all(axis=1)
    t_r, x_r = pm.t_r[sel], pm.xy_r[sel]
    if len(t_r) < MIN_MATCHES:
        return float("nan"), len(t_r)
    shifts = centre + np.arange(-half, half + 1e-9, GRID_FRAMES)
    energy = np.full(len(shifts), np.nan)
    for k, s in enumerate(shifts):
        x_c = interpolate_track(t_r - s / pm.fps_c, pm.t_c_in_r, pm.xy_c)
        ok = np.isfinite(x_c).all(axis=1)
        if ok.sum() >= MIN_MATCHES:
            d = sampson_px(pm.F_rc, x_r[ok], x_c[ok])
            energy[k] = np.mean(np.minimum(d, THRESHOLD_PX) ** 2)
    if not np.isfinite(energy).any():
        return float("nan"), 0
    k = int(np.nanargmin(energy))
    if k in (0, len(shifts) - 1):  # at the edge of the search: not a minimum, no shift
        return float("nan"), 0
    best = float(shifts[k])
    if 0 < k < len(shifts) - 1 and np.isfinite(energy[k - 1:k + 2]).all():
        e0, e1, e2 = energy[k - 1:k + 2]
        curv = e0 - 2 * e1 + e2
        if curv > 0:
            best += 0.5 * (e0 - e2) / curv * GRID_FRAMES
    x_c = interpolate_track(t_r - best / pm.fps_c, pm.t_c_in_r, pm.xy_c)
    return best, int(np.isfinite(x_c).all(axis=1).sum())


def windows(bundle, gt, width_s: float) -> list[tuple[float, float]]:
    ends = [gt.offsets_s[v.name] + (1 + gt.drift_ppm[v.name] * 1e-6) * v.timestamps_s[[0, -1]]
            for v in bundle.videos]
    g0, g1 = min(e[0] for e in ends), max(e[1] for e in ends)
    starts = np.arange(np.floor(g0 / width_s) * width_s, g1, width_s)
    return [(float(s), float(s + width_s)) for s in starts]


def line_fit(centres_s: np.ndarray, shifts_frames: np.ndarray, fps_c: float, mid_s: float):
    """(value at mid_s in frames, slope as a rate error in ppm, rms of the residual in frames,
    largest jump between neighbouring windows after the line, windows used). The line is
    Theil-Sen's (scipy.stats.theilslopes: the median of the pairwise slopes), so that a window
    whose minimum is a wrong one (a hover, a short overlap) does not tilt it."""
    ok = np.isfinite(shifts_frames)
    if ok.sum() < 3:
        return (float("nan"),) * 4 + (int(ok.sum()),)
    slope, at_mid, *_ = theilslopes(shifts_frames[ok], centres_s[ok] - mid_s)
    res = shifts_frames[ok] - (at_mid + slope * (centres_s[ok] - mid_s))
    return (float(at_mid), float(slope / fps_c * 1e6), float(np.sqrt(np.mean(res ** 2))),
            float(np.max(np.abs(np.diff(res)))), int(ok.sum()))


def collinear_share(xy: np.ndarray, tol_px: float = 1e-3) -> tuple[float, float]:
    """(share of runs of three consecutive detected frames whose middle lies within tol_px of
    its neighbours' midpoint, median |second difference| px), on the file's own (distorted) px.
    Positions interpolated linearly between raw frames have a zero second difference inside each
    raw interval; measured positions have the detector's noise."""
    ok = np.isfinite(xy).all(axis=1)
    trip = ok[:-2] & ok[1:-1] & ok[2:]
    d2 = xy[2:] - 2 * xy[1:-1] + xy[:-2]
    mag = np.hypot(d2[trip, 0], d2[trip, 1])
    if not len(mag):
        return float("nan"), float("nan")
    return float(np.mean(mag < tol_px)), float(np.median(mag))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=DATA, help="the dataset folder (default: %(default)s)")
    ap.add_argument("--window-s", type=float, default=60.0, help="window width, global seconds (default: 60)")
    ap.add_argument("--fine-window-s", type=float, default=10.0,
                    help="the finer windows of the jump check, c against cam0 (default: 10 s)")
    ap.add_argument("--cameras", default="cam0,cam1,cam2,cam3,cam4,cam5",
                    help="the cameras c examined, comma-separated (default: all)")
    args = ap.parse_args(argv)
    if not (args.data / "detections").is_dir():
        print(f"error: {args.data}: not the drone dataset (no detections/ folder)", file=sys.stderr)
        return 2
    if args.window_s <= 0 or args.fine_window_s <= 0:
        print("error: --window-s and --fine-window-s must be positive", file=sys.stderr)
        return 2
    t_start = time.perf_counter()
    bundle, gt = import_drone(args.data)
    if gt is None:
        print(f"error: {args.data}: no README time tables", file=sys.stderr)
        return 2
    cams = [c for c in args.cameras.split(",") if c]
    unknown = [c for c in cams if c not in bundle.names]
    if unknown:
        print(f"error: unknown cameras {unknown}; the dataset has {bundle.names}", file=sys.stderr)
        return 2

    maps: dict[tuple[str, str], PairMap] = {}
    for c in cams:
        for r in REFS:
            if r != c:
                pm = pair_map(bundle, gt, r, c)
                if pm is not None:
                    maps[(c, r)] = pm
    t_fit = time.perf_counter() - t_start

    wins = windows(bundle, gt, args.window_s)
    centres = np.array([0.5 * (a + b) for a, b in wins])
    mid = 0.5 * (wins[0][0] + wins[-1][1])
    print(f"local shift minus the README's prediction, in frames of camera c (windows of {args.window_s:g} s "
          f"of cam0's clock; '-': fewer than {MIN_MATCHES} matched detections, or the energy's lowest "
          f"shift at the edge of the ±{HALF_RANGE_FRAMES:g}-frame search)")
    print("positive: c's detection that matches r's at r's time tau is the one the README maps to tau - shift\n")
    summary = []
    for c in cams:
        refs = [r for r in REFS if (c, r) in maps]
        if not refs:
            continue
        shifts = {r: np.array([local_shift_frames(maps[(c, r)], a, b)[0] for a, b in wins]) for r in refs}
        head = f"c = {c} ({maps[(c, refs[0])].fps_c:g} fps)"
        print(f"{head:24}" + "".join(f"{'r=' + r:>9}" for r in refs))
        for k, (a, b) in enumerate(wins):
            print(f"  {a:7.0f} .. {b:5.0f} s     " + "".join(
                f"{shifts[r][k]:+9.2f}" if np.isfinite(shifts[r][k]) else f"{'-':>9}" for r in refs))
        for r in refs:
            pm = maps[(c, r)]
            summary.append((c, r, pm) + line_fit(centres, shifts[r], pm.fps_c, mid))
        print()

    print(f"per pair: a Theil-Sen line through the windows' shifts (frames of c at the middle of the recording, "
          f"{mid:.0f} s; slope as a rate error, ppm), its rms residual and largest jump between "
          f"neighbouring windows (frames); the whole-recording F at the README's map: inlier share "
          f"(< {THRESHOLD_PX:g} px) and median Sampson px")
    print(f"{'c':5} {'r':5} {'mid frames':>10} {'slope ppm':>10} {'rms fr':>7} {'jump fr':>8} {'windows':>7} "
          f"{'F inliers':>9} {'median px':>9}")
    for c, r, pm, at_mid, ppm, rms, jump, n in summary:
        print(f"{c:5} {r:5} {at_mid:+10.2f} {ppm:+10.0f} {rms:7.2f} {jump:8.2f} {n:7d} {pm.inlier_share:9.2f} "
              f"{pm.median_px:9.2f}")

    fine = windows(bundle, gt, args.fine_window_s)
    fc = np.array([0.5 * (a + b) for a, b in fine])
    print(f"\njump check: each camera c against cam0 (cam0 against cam2) in windows of {args.fine_window_s:g} s (searched ±"
          f"{FINE_HALF_FRAMES:g} frames around the line above), shift minus a Theil-Sen line through them "
          f"(frames of c): rms, largest jump between neighbours, median |residual|, share of windows over 1 frame")
    print(f"{'c':5} {'r':5} {'windows':>7} {'slope ppm':>10} {'rms fr':>7} {'jump fr':>8} {'median |res|':>12} "
          f"{'|res| > 1':>9}")
    for c in cams:
        r = next((r for r in REFS if (c, r) in maps), None)
        if r is None:
            continue
        pm = maps[(c, r)]
        # around the coarse windows' line (± 8 frames): a jump of the shift within that shows
        at_mid, ppm = next((m, p) for cc, rr, _, m, p, *_ in summary if (cc, rr) == (c, r))
        guess = at_mid + ppm * 1e-6 * pm.fps_c * (fc - mid) if np.isfinite(at_mid) else np.zeros(len(fc))
        s = np.array([local_shift_frames(pm, a, b, g, FINE_HALF_FRAMES)[0] for (a, b), g in zip(fine, guess)])
        at_mid, ppm, rms, jump, n = line_fit(fc, s, pm.fps_c, mid)
        ok = np.isfinite(s)
        res = np.abs(s[ok] - (at_mid + ppm * 1e-6 * pm.fps_c * (fc[ok] - mid)))
        print(f"{c:5} {r:5} {n:7d} {ppm:+10.0f} {rms:7.2f} {jump:8.2f} {np.median(res):12.2f} "
              f"{np.mean(res > 1.0):9.2f}")

    print("\nlinear-interpolation signature (the detection files' px): share of three consecutive detected "
          "frames whose middle lies within 0.001 px of its neighbours' midpoint; median |second difference|")
    print(f"{'camera':7} {'fps':>7} {'frames':>7} {'collinear':>9} {'median |d2| px':>14}")
    for name in bundle.names:
        cam = read_drone_camera(args.data, name)
        xy = np.full((int(cam.frames.max()), 2), np.nan)
        xy[cam.frames - 1] = cam.xy_px  # by frame number: a missing row breaks a triple
        share, med = collinear_share(xy)
        print(f"{name:7} {cam.fps:7.3f} {len(cam.frames):7d} {share:9.3f} {med:14.3f}")
    print(f"\n{len(maps)} pair fits in {t_fit:.1f} s, total {time.perf_counter() - t_start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
