"""The accuracy floor of the caliscope session: synchronize it from the ChArUco corners in
calibration/extrinsic/xy.csv (perfect cross-view tracks, already matched by id) with the
session's calibration and per-frame timestamps, and print each video's error against
timestamps.csv in ms.

    PYTHONPATH=. python examples/caliscope_charuco_floor.py

Measured: cam_1 55.2 ms, cam_2 1.1 ms, cam_3 2.5 ms. Whatever the cues, cam_1 comes out about
50 ms off the recorded frame_time, so part of the Stage 0 error on this session is in the data.
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from vs_inspect.bench.datasets import CALISCOPE, caliscope_cut, load_caliscope  # noqa: E402
from vs_inspect.sync.run import sync_bundle  # noqa: E402

D = REPO.parent / "shared" / "data" / CALISCOPE


def main() -> None:
    session = load_caliscope(D)
    bundle = caliscope_cut(session, {}, "caliscope/uncut").bundle  # the corners as tracks, no cut
    res = sync_bundle(bundle, progress=False)
    truth, ref = bundle.gt_offsets_s, res.reference
    for n in session.names[1:]:
        err = ((res.offsets_s[n] - res.offsets_s[ref]) - (truth[n] - truth[ref])) * 1000
        print(f"{n}: offset {res.offsets_s[n]:+.4f} s, error {abs(err):.1f} ms")


if __name__ == "__main__":
    main()
