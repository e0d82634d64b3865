"""Classical synchronization peers, run beside vs_inspect on the same data in the benchmark.

- motion_xcorr: one scalar per frame (amount of image motion) cross-correlated between videos,
  what video-mode sync tools do without audio.
- ransac_inlier: for each candidate offset, fit F to the shifted track pairs with RANSAC and
  score the inlier count (the paper's ablation baseline after Albl et al.); no camera poses.

Both end in the same Stage 2 solver as vs_inspect (vs_inspect.sync.solve.solve_offsets).
"""

from .common import PeerPair, PeerResult, solve_peer
from .motion_xcorr import (motion_signal_from_frames, motion_signal_from_tracks, sync_motion_xcorr,
                           sync_motion_xcorr_videos, xcorr_offset)
from .ransac_inlier import ransac_inlier_landscape, sync_ransac_inlier

__all__ = ["PeerPair", "PeerResult", "solve_peer", "motion_signal_from_frames",
           "motion_signal_from_tracks", "sync_motion_xcorr", "sync_motion_xcorr_videos", "xcorr_offset",
           "ransac_inlier_landscape", "sync_ransac_inlier"]
