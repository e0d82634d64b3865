"""The accuracy floor of the caliscope session: synchronize it from the ChArUco corners in
calibration/extrinsic/xy.csv (perfect cross-view tracks, already matched by id) with the
session's calibration, and print each video's error against timestamps.csv in ms.

    PYTHONPATH=. python examples/caliscope_charuco_floor.py

Measured: cam_1 46 ms, cam_2 2 ms, cam_3 18 ms. Whatever the cues, cam_1 comes out about 50 ms
off the recorded frame_time, so part of the Stage 0 error on this session is in the data.
"""

from __future__ import annotations

import collections
import csv
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from vs_inspect.io.calibration import load_calibration, to_camera_track, undistort_points  # noqa: E402
from vs_inspect.sync.run import sync_bundle  # noqa: E402
from vs_inspect.types import CueBundle, TrackPairs, Tracks, VideoInfo  # noqa: E402

D = REPO.parent / "shared" / "data" / "caliscope_post_optimization"


def main() -> None:
    names = [f"cam_{i}" for i in range(4)]
    cal = load_calibration(D / "camera_array.toml", names)
    times = collections.defaultdict(dict)
    for r in csv.DictReader(open(D / "calibration" / "extrinsic" / "timestamps.csv")):
        times[int(r["cam_id"])][int(r["sync_index"])] = float(r["frame_time"])
    s0 = min(min(v) for v in times.values())
    n_frames = len(times[0])
    pts = collections.defaultdict(dict)
    for r in csv.DictReader(open(D / "calibration" / "extrinsic" / "xy.csv")):
        pts[int(r["cam_id"])].setdefault(int(r["keypoint_id"]), {})[int(r["sync_index"]) - s0] = (
            float(r["img_loc_x"]), float(r["img_loc_y"]))
    ids = sorted(set().union(*[set(p) for p in pts.values()]))
    tracks, cams = {}, {}
    for c in range(4):
        xy = np.full((len(ids), n_frames, 2), np.nan)
        for i, pid in enumerate(ids):
            for k, v in pts[c].get(pid, {}).items():
                xy[i, k] = v
        n = f"cam_{c}"
        tracks[n] = Tracks(undistort_points(cal[n], xy))
        cams[n] = to_camera_track(cal[n])
    idx = np.stack([np.arange(len(ids))] * 2, axis=1)
    pairs = {(a, b): TrackPairs(a, b, idx) for i, a in enumerate(names) for b in names[i + 1:]}
    videos = tuple(VideoInfo.constant_rate(n, 1280, 720, n_frames, 6.0) for n in names)
    res = sync_bundle(CueBundle(videos, cams, tracks, pairs), progress=False)
    t0 = {n: times[int(n[-1])][s0] for n in names}
    for n in names[1:]:
        err = (res.offsets_s[n] - (t0[n] - t0["cam_0"])) * 1000
        print(f"{n}: offset {res.offsets_s[n]:+.4f} s, error {abs(err):.1f} ms")


if __name__ == "__main__":
    main()
