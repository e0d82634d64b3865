"""The rendered scenes' names, their rendering settings and the named sets."""

from __future__ import annotations

import pytest

from vs_inspect.bench.scenes import DEFAULT_SET, RENDERED, SCENE_SETS, scene_config
from vs_inspect.commands.demo import DEMO_SCENE


def test_arc_scene_names_and_their_rendering_settings():
    cfg = scene_config("a60_c4m1_s12")
    assert (cfg.arc_deg, cfg.cameras, cfg.moving, cfg.seed, cfg.seconds) == (60.0, 4, 1, 12, 6.0)
    assert (cfg.width, cfg.height, cfg.fps) == (640, 480, 30.0)
    mixed = scene_config("a45_c5m2_s76_mixed")
    assert (mixed.arc_deg, mixed.cameras, mixed.moving, mixed.seed) == (45.0, 5, 2, 76)
    assert mixed.fps is None  # drawn per camera by the renderer


def test_rendered_and_demo_names():
    cfg = scene_config("rendered_s3")
    assert cfg.seed == 3 and (cfg.width, cfg.height, cfg.cameras, cfg.moving, cfg.variable_rate) == (480, 360, 4, 1, 1)
    assert scene_config("rendered_s0") == RENDERED
    assert scene_config("demo") == DEMO_SCENE


@pytest.mark.parametrize("name, says", [("a60_c4m1", "not a scene name"), ("a0_c4m1_s1", "outside 1-360"),
                                        ("a60_c2m2_s1", "one of them static"), ("a60_c1m0_s1", "at least 2"),
                                        ("a60_c4m1_s1_mix", "not a scene name"), ("rendered", "not a scene name")])
def test_bad_names_are_refused_with_what_is_wrong(name, says):
    with pytest.raises(ValueError, match=says):
        scene_config(name)


def test_the_scene_sets_share_no_seed_and_mix_the_same_way():
    arcs = {k: v for k, v in SCENE_SETS.items() if k != "rendered"}
    seeds = {k: {scene_config(n).seed for n in names} for k, names in arcs.items()}
    for a in seeds:
        for b in seeds:
            assert a == b or not seeds[a] & seeds[b], (a, b)
    for k in arcs:
        if k.startswith("seeds-"):
            lo, hi = map(int, k.removeprefix("seeds-").split("-"))
            assert seeds[k] == set(range(lo, hi + 1)), k
    assert seeds["mixed-rates"] == set(range(70, 82)) and len(SCENE_SETS["seeds-0-9"]) == 14
    later = ("seeds-22-33", "seeds-34-45", "seeds-46-57", "seeds-58-69", "mixed-rates")
    kinds = {k: sorted(n.rsplit("_s", 1)[0] for n in SCENE_SETS[k]) for k in ("seeds-10-21",) + later}
    assert all(kinds[k] == kinds["seeds-10-21"] for k in later)
    assert all((scene_config(n).fps is None) == (k == "mixed-rates") for k, names in arcs.items() for n in names)
    assert DEFAULT_SET in SCENE_SETS and SCENE_SETS["rendered"] == ("rendered_s0", "rendered_s1", "rendered_s2")
