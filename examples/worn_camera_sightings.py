"""Evidence: each direction of each pair of a worn-camera sightings run (geometry/sightings.py).

`vs-inspect sync` keeps, in its cue bundle, the head a person detector found in every frame of
every video (when a camera moves and mediapipe is installed) and times a pair by the heads that
sit on the other, worn camera's projected centre, both directions together (sync/sightings.py).
This script shows each direction on its own, per ordered pair (a sees the wearer of b): the peak
Δ (the middle of the run of candidates with the most heads within --radius-px of b's projected
centre, as Stage 1 takes it), its rival farther than --exclude-frames away, the median distance
at the peak, and the error against the truth of VisualSync clip names; then the peak refined as
Stage 1 refines an accepted one (sync/sightings.refine_peak: one constant shift between the heads
and b's centre fitted with Δ) with its error and the shift. It reads a finished run's cues only.

    vs-inspect sync ../shared/data/visualsync_clips/fencing1/*.mp4 --out /tmp/f1 --no-rrd
    PYTHONPATH=. python examples/worn_camera_sightings.py /tmp/f1
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from vs_inspect.bench.videos import clip_truth
from vs_inspect.geometry.sightings import sighting_peak
from vs_inspect.io.bundle import read_bundle
from vs_inspect.sync.config import LandscapeConfig, SightingConfig
from vs_inspect.sync.landscape import search_offsets
from vs_inspect.sync.sightings import direction_landscape, refine_peak


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, help="output folder of vs-inspect sync (its cues/ bundle)")
    ap.add_argument("--radius-px", type=float, default=10.9, help="a head this near b's centre counts (px)")
    ap.add_argument("--exclude-frames", type=float, default=3.0, help="a rival peak is farther than this")
    args = ap.parse_args()
    bundle = read_bundle(args.run / "cues")
    infos = {v.name: v for v in bundle.videos}
    names = list(infos)
    if not bundle.heads:
        print("worn_camera_sightings: the run's bundle has no heads (no camera moved, mediapipe missing, "
              "or --no-heads)", file=sys.stderr)
        return 2
    try:
        truth = clip_truth([Path(n) for n in names])
    except Exception:  # not VisualSync clip names: no truth column
        truth = None
    print(f"{'a sees the wearer of b':58s} {'heads':>5s} {'best Δ s':>9s} {'near':>5s} {'rival':>5s} "
          f"{'median px':>9s} {'true Δ s':>9s} {'error frames':>12s} {'fitted Δ s':>10s} {'error':>6s}  shift")
    for a in names:
        if a not in bundle.heads:
            continue
        va, head = infos[a], bundle.heads[a]
        for b in names:
            vb = infos[b]
            if b == a or not bundle.cameras[b].is_moving:
                continue
            grid = search_offsets(va, vb, LandscapeConfig())  # Stage 1's candidates, Δ of (a, b)
            land = direction_landscape(bundle, a, b, grid, args.radius_px)
            coarse_s = max(va.frame_interval_s, vb.frame_interval_s)
            true_d = truth[b] - truth[a] if truth else None
            if land.near.max() == 0:
                print(f"{a + ' sees ' + b:58s} {int(np.isfinite(head[:, 0]).sum()):5d}   no head near b's centre "
                      f"at any offset")
                continue
            peak, lo, _, rival = sighting_peak(land.offsets_s, land.near, args.exclude_frames * coarse_s)
            at = int(np.argmin(np.abs(land.offsets_s - peak)))
            err = f"{(peak - true_d) / coarse_s:+.1f}" if truth else "-"
            # Stage 1's refinement of an accepted peak, this direction alone
            fit = refine_peak(bundle, a, [(a, b)], peak, coarse_s, {a: args.radius_px},
                              SightingConfig().refine_frames)
            fitted = fit.offset_s
            shift = (f"({fit.shift_px[a][0]:+.1f}, {fit.shift_px[a][1]:+.1f}) px, rms {fit.rms_px:.1f} px"
                     if fit.refined else "not refined")
            fitted_err = f"{(fitted - true_d) / coarse_s:+.1f}" if truth else "-"
            print(f"{a + ' sees ' + b:58s} {int(np.isfinite(head[:, 0]).sum()):5d} {peak:+9.2f} "
                  f"{land.near[lo]:5d} {rival:5d} {land.median_px[at]:9.1f} "
                  f"{'' if true_d is None else f'{true_d:+9.2f}':>9s} {err:>12s} {fitted:+10.3f} {fitted_err:>6s}  {shift}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
