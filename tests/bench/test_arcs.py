"""The arc scenes' names, per-offset errors in frames and the safety count."""

from __future__ import annotations

import pytest

from vs_inspect.bench.arcs import SCENE_SETS, frame_errors, parse_scene, summarize


def test_parse_scene_and_its_rendering_settings():
    sc = parse_scene("a60_c4m1_s12")
    assert (sc.arc_deg, sc.cameras, sc.moving, sc.seed) == (60.0, 4, 1, 12)
    cfg = sc.scene_config()
    assert (cfg.arc_deg, cfg.cameras, cfg.moving, cfg.seed, cfg.seconds) == (60.0, 4, 1, 12, 6.0)
    assert (cfg.width, cfg.height, cfg.fps) == (640, 480, 30.0)


@pytest.mark.parametrize("name, says", [("a60_c4m1", "not a scene name"), ("a0_c4m1_s1", "outside 1-360"),
                                        ("a60_c2m2_s1", "one of them static"), ("a60_c1m0_s1", "at least 2")])
def test_parse_scene_refuses_bad_names(name, says):
    with pytest.raises(ValueError, match=says):
        parse_scene(name)


def test_the_scene_sets_share_no_seed():
    seeds = {k: {parse_scene(n).seed for n in names} for k, names in SCENE_SETS.items()}
    for a in seeds:
        for b in seeds:
            assert a == b or not seeds[a] & seeds[b], (a, b)
    assert seeds["held-out-2"] == set(range(22, 34))
    assert seeds["held-out-3"] == set(range(34, 46))
    # the later held-out sets mix arcs and cameras as the first does
    kinds = {k: sorted(n.rsplit("_s", 1)[0] for n in SCENE_SETS[k]) for k in ("held-out", "held-out-2", "held-out-3")}
    assert kinds["held-out"] == kinds["held-out-2"] == kinds["held-out-3"]


def test_frame_errors_against_the_results_reference():
    truth = {"cam0": 0.0, "cam1": 0.5, "cam2": -1.0}
    # cam1 is the reference used; cam2 one frame late against it, cam0 unresolved
    offsets = {"cam0": None, "cam1": 0.0, "cam2": -1.5 + 1 / 30}
    err = frame_errors("cam1", offsets, truth, fps=30.0)
    assert err["cam0"] is None
    assert err["cam2"] == pytest.approx(1.0)
    assert "cam1" not in err
    # a reference without an offset leaves nothing resolved
    assert frame_errors("cam0", offsets, truth, fps=30.0) == {"cam1": None, "cam2": None}


def test_summarize_counts_the_offsets_over_two_frames():
    s = summarize([0.2, -0.9, 1.5, -2.5, None, 36.6])
    assert (s.offsets, s.resolved, s.within_1, s.from_1_to_2, s.over_2) == (6, 5, 2, 1, 2)
    assert s.median_abs_frames == pytest.approx(1.5)
    assert s.max_abs_frames == pytest.approx(36.6)
    empty = summarize([None, None])
    assert (empty.resolved, empty.over_2, empty.median_abs_frames) == (0, 0, None)
