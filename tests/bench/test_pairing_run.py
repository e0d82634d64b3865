"""vs-inspect bench-pairing: its options and the scenes it renders."""

from __future__ import annotations

import pytest

from vs_inspect.bench.pairing_run import RENDERED, scene_of
from vs_inspect.cli import build_parser
from vs_inspect.commands.demo import DEMO_SCENE


def test_the_scenes_and_their_folders():
    assert scene_of("rendered") == (RENDERED, "rendered")
    cfg, folder = scene_of("rendered", 3)
    assert (cfg.seed, cfg.cameras, cfg.moving, folder) == (3, 4, 1, "rendered_s3")
    assert scene_of("demo") == (DEMO_SCENE, "demo")
    with pytest.raises(ValueError, match="rendered or demo"):
        scene_of("other")


def test_options():
    a = build_parser().parse_args(["bench-pairing", "demo", "--geometric", "triangles"])
    assert (a.scene, a.geometric, a.seed) == ("demo", "triangles", 0)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["bench-pairing", "other"])
