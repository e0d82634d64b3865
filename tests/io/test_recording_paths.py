"""The recording's entity paths, named once: video names as entity-path parts, and two names
that would share one entity refused."""

from __future__ import annotations

import pytest

from vs_inspect.errors import InputError
from vs_inspect.io import recording_paths as P


def test_entity_paths():
    assert P.entity_name("cam 1/x.mp4") == "cam_1_x_mp4"
    assert P.entity_name("") == "_"
    assert P.pair_key("a b", "c") == "a_b__c"
    assert P.pair_path("a b", "c") == "pairs/a_b__c"
    assert P.pair_landscape_path("a", "b") == "pairs/a__b/landscape"
    assert P.pair_decision_path("a", "b") == "pairs/a__b/decision"
    assert P.pair_epipolar_path("a", "b") == "pairs/a__b/epipolar"
    assert P.video_path("c 0") == "videos/c_0"
    assert (P.video_asset_path("c0"), P.video_image_path("c0"), P.video_mask_path("c0"),
            P.video_tracks_path("c0")) == ("videos/c0/video", "videos/c0/image", "videos/c0/mask",
                                           "videos/c0/tracks")
    assert P.camera_path("c0") == "world/cameras/c0"
    assert P.camera_trail_path("c0") == "world/camera_paths/c0"
    assert P.trajectory_path("a", "b") == "world/trajectories/a__b"
    assert P.solve_residual_path("a", "b") == "sync/solve/residual_ms/a__b"
    assert P.solve_weight_path("a", "b") == "sync/solve/weight/a__b"
    assert P.log_path("stage 0") == "log/stage_0"


def test_entity_names_must_not_collide():
    assert P.check_entity_names(["cam0", "cam 1"]) == {"cam0": "cam0", "cam_1": "cam 1"}
    with pytest.raises(InputError, match=r"'cam\.1' and 'cam_1' would share the recording entity 'cam_1'"):
        P.check_entity_names(["cam.1", "cam_1"])
    known = P.check_entity_names(["a.b"])
    with pytest.raises(InputError, match="'a.b' and 'a b'"):
        P.check_entity_names(["a b"], known)
    assert P.check_entity_names(["a.b"], known) == known  # the same name again is no collision
