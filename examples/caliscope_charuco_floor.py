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

from vs_inspect.bench.datasets import CALISCOPE, corner_sync_bias_s, load_caliscope  # noqa: E402

D = REPO.parent / "shared" / "data" / CALISCOPE


def main() -> None:
    session = load_caliscope(D)
    for n, bias in corner_sync_bias_s(session).items():
        if n != session.names[0]:
            print(f"{n}: error {abs(bias) * 1000:.1f} ms ({bias * 1000:+.1f} ms against frame_time)")


if __name__ == "__main__":
    main()
