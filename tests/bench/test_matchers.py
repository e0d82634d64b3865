"""The matcher bench's per-pair measurement on a pair with known geometry: a textured plane seen by
two cameras that differ by a sideways translation (epipolar lines are the image rows)."""

from __future__ import annotations

import numpy as np

from vs_inspect.bench.matchers import (
    View,
    format_row,
    make_bench_matcher,
    measure_pair,
    summary_table,
)

from ..cues.scenes import texture


def test_measure_pair_counts_matches_against_the_true_geometry():
    img = np.dstack([texture(240, 320, 7 + k, blur=1.5) for k in range(3)])
    shifted = np.roll(img, -8, axis=1)  # x_b = x_a - 8: f * tx / Z = 8 px for the plane
    moving = np.zeros((240, 320), bool)
    moving[60:180, 180:300] = True
    K = np.array([[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]])
    Ta, Tb = np.eye(4), np.eye(4)
    Tb[0, 3] = -0.08  # b's centre 0.08 to the right of a's, plane at Z = 3
    a = View("a", img, moving, K, np.zeros(5), Ta)
    b = View("b", shifted, np.roll(moving, -8, axis=1), K, np.zeros(5), Tb)
    matchers = {m: make_bench_matcher(m, top_k=1024) for m in ("sift", "xfeat-mnn")}
    rows = measure_pair("plane", "a|b@0", a, b, matchers)
    assert [r.method for r in rows] == ["sift", "xfeat-mnn"]
    for r in rows:
        assert r.reference == "true"
        assert r.bg_matches > 100 and r.mov_matches > 30, format_row(r)
        # same row in both images = on the epipolar line (matches across the wrapped border are not)
        assert r.bg_consistent > 0.9 and r.mov_consistent > 0.9, format_row(r)
        assert r.seconds > 0
    table = summary_table(rows)
    assert table.count("| plane (true) |") == 2
