"""Body landmarks per frame with MediaPipe's BlazePose (its weights ship inside the mediapipe 0.10.14
wheel; Apache-2.0), saved for examples/worn_camera_sightings.py.

It runs in its own environment, not in vs_inspect's: mediapipe 0.10.14 needs protobuf < 5 and
declares opencv-contrib-python, which would replace the headless OpenCV:

    python3.11 -m venv /tmp/mp && /tmp/mp/bin/pip install --no-deps mediapipe==0.10.14 && \\
      /tmp/mp/bin/pip install numpy opencv-python-headless absl-py attrs flatbuffers matplotlib "protobuf>=4.25.3,<5"
    /tmp/mp/bin/python examples/detect_heads.py ../shared/data/visualsync_clips/fencing1/*.mp4 --out heads.npz

BlazePose follows one person, the most prominent: in a frame with several people it may pick any
of them, and the sightings script counts on that being the exception. Its landmark smoothing is
off: smoothed, the heads lagged their motion and the sightings on fencing1 came out 1.5 frames
late instead of 1.0 (README, "A worn camera seen by another"). Output: one (T,33,3) array
per video (file stem): x, y in full-resolution px (distorted, as decoded) and the landmark's
visibility, NaN where no person was found.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("videos", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True, help="npz to write")
    args = ap.parse_args()
    try:
        import mediapipe as mp
        pose_solution = mp.solutions.pose
    except (ImportError, AttributeError) as e:
        print(f"detect_heads: needs mediapipe 0.10.14 with its legacy solutions (see --help): {e}", file=sys.stderr)
        return 2
    out = {}
    for path in args.videos:
        cap = cv2.VideoCapture(str(path))
        if not cap.isOpened():
            print(f"detect_heads: cannot open {path}", file=sys.stderr)
            return 2
        rows, t0 = [], time.perf_counter()
        with pose_solution.Pose(static_image_mode=False, model_complexity=1, smooth_landmarks=False) as pose:
            while True:
                ok, bgr = cap.read()
                if not ok:
                    break
                h, w = bgr.shape[:2]
                found = pose.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)).pose_landmarks
                rows.append(np.array([[p.x * w, p.y * h, p.visibility] for p in found.landmark])
                            if found else np.full((33, 3), np.nan))
        if not rows:
            print(f"detect_heads: no frame decoded from {path}", file=sys.stderr)
            return 2
        out[path.stem] = np.stack(rows)
        print(f"{path.stem}: a person in {int(np.isfinite(out[path.stem][:, 0, 0]).sum())} of {len(rows)} frames "
              f"({time.perf_counter() - t0:.1f} s)")
    tmp = args.out.with_name(args.out.name + ".part.npz")
    np.savez(tmp, **out)
    tmp.replace(args.out)  # complete or absent
    return 0


if __name__ == "__main__":
    sys.exit(main())
