"""The rendered world: the VTK camera agrees with OpenCV's pinhole model, scenes are deterministic,
and the true cue bundle of a rendered scene gives back the true offsets."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vs_inspect.geometry.epipolar import project
from vs_inspect.synth.world import SceneConfig, make_scene, make_world, observe_points

TINY = SceneConfig(cameras=3, moving=1, seconds=2.0, width=160, height=120, fps=24.0,
                   max_offset_s=0.4, points_per_object=30, seed=3)


def test_scene_is_deterministic_from_seed():
    a, b = make_scene(TINY), make_scene(TINY)
    g = np.linspace(-1, 3, 7)
    fresh = make_world.__wrapped__(TINY.seed, TINY.points_per_object)  # not the cached one
    np.testing.assert_array_equal(a.world.points_at(g)[0], fresh.points_at(g)[0])
    for ba, bf in zip(a.world.bodies, fresh.bodies):
        np.testing.assert_array_equal(ba.texture, bf.texture)
    for ca, cb in zip(a.cameras, b.cameras):
        assert ca.offset_s == cb.offset_s
        np.testing.assert_array_equal(ca.K, cb.K)
        np.testing.assert_array_equal(ca.cam_from_world(), cb.cam_from_world())
    c = make_scene(SceneConfig(**{**TINY.__dict__, "seed": 4}))
    assert c.cameras[1].offset_s != a.cameras[1].offset_s
    assert not np.allclose(c.world.points_at(g)[0], a.world.points_at(g)[0])


def test_cameras_differ_and_moving_camera_moves():
    s = make_scene(SceneConfig(cameras=4, moving=1, seconds=2.0, seed=0))
    Ks = [c.K for c in s.cameras]
    assert all(abs(K[0, 0] - K[1, 1]) > 1e-6 for K in Ks)  # fx != fy everywhere
    assert len({round(K[0, 2], 6) for K in Ks}) == 4
    mov = [c for c in s.cameras if c.moving]
    assert len(mov) == 1
    T = mov[0].cam_from_world()
    centres = -np.einsum("tji,tj->ti", T[:, :3, :3], T[:, :3, 3])
    assert np.linalg.norm(centres[-1] - centres[0]) > 0.05  # it walks
    assert len({c.num_frames for c in s.cameras}) > 1  # partial overlap: different lengths


@pytest.mark.parametrize("size", [(160, 120), (203, 151)])
def test_render_agrees_with_opencv_projection(size):
    """Project every tracked surface point of every moving object with the scene's K and
    cam_from_world, and find that object's id colour in the segmentation render at that pixel."""
    from vs_inspect.synth.render import SceneRenderer

    W, H = size
    scene = make_scene(SceneConfig(cameras=3, moving=2, seconds=1.0, width=W, height=H,
                                   points_per_object=80, seed=1))
    world = scene.world
    ids = [b.id_rgb for b in world.bodies]
    assert len(set(ids)) == len(ids) and (0, 0, 0) not in ids  # one colour per body
    body_rgb = np.array([b.id_rgb for b in world.bodies])[world.track_body]  # (M,3)
    checked = {"exact": 0, "near": 0, "total": 0, "boxes": 0}
    with SceneRenderer(world, W, H, segmentation=True) as r:
        for cam in scene.cameras:
            poses = cam.pose_fn(cam.global_times_s)
            for k in (0, cam.num_frames // 2, cam.num_frames - 1):
                g = cam.global_times_s[k]
                rgb, depth = r.render(g, cam.K, poses[k])
                xy, d = observe_points(world, cam, np.array([g]), poses[k])
                xy, d = xy[:, 0], d[:, 0]
                # the same projection through the package's geometry
                X, _ = world.points_at(np.array([g]))
                ok = np.isfinite(xy[:, 0])
                np.testing.assert_allclose(project(cam.K, poses[k], X[:, 0])[ok], xy[ok])
                for m in np.flatnonzero(ok):
                    u, v = xy[m]
                    c, rr = int(round(u)), int(round(v))
                    if not (1 <= c < W - 1 and 1 <= rr < H - 1):
                        continue
                    if d[m] > depth[rr, c] + 0.02:  # hidden behind something else
                        continue
                    want = body_rgb[m]
                    patch = rgb[rr - 1:rr + 2, c - 1:c + 2].reshape(-1, 3)
                    checked["total"] += 1
                    checked["exact"] += bool(np.all(rgb[rr, c] == want))
                    checked["near"] += bool(np.any(np.all(patch == want, axis=1)))
                _check_box_silhouettes(world, cam, g, poses[k], rgb, checked)
    assert checked["total"] > 100, checked
    # within 1 px: all but points on sub-pixel slivers (a box corner seen edge-on)
    assert checked["near"] >= 0.99 * checked["total"], checked
    # at the pixel itself: all but points within half a pixel of a silhouette edge
    assert checked["exact"] >= 0.7 * checked["total"], checked
    assert checked["boxes"] >= 6, checked


def _check_box_silhouettes(world, cam, g, cam_from_world, rgb, checked):
    """A box's rendered pixels (pixel centres inside its silhouette) must span exactly the pixel
    centres inside the bounding box of its projected corners: this pins the principal point
    and focal lengths to well under a pixel (a half-pixel shift of the convention fails)."""
    H, W = rgb.shape[:2]
    for b in world.bodies:
        if len(b.mesh.points) != 24:  # boxes only (convex, silhouette = hull of the corners)
            continue
        P = b.world_from_body(np.array([g]))[0]
        xy = project(cam.K, cam_from_world, b.mesh.points @ P[:3, :3].T + P[:3, 3])
        if not np.all(np.isfinite(xy)) or xy[:, 0].min() < 1 or xy[:, 1].min() < 1 \
                or xy[:, 0].max() > W - 2 or xy[:, 1].max() > H - 2:
            continue
        mask = np.all(rgb == np.array(b.id_rgb), axis=2)
        ys, xs = np.nonzero(mask)
        if len(xs) < 30:
            continue
        lo_x, hi_x = xy[:, 0].min(), xy[:, 0].max()
        lo_y, hi_y = xy[:, 1].min(), xy[:, 1].max()
        # occlusion can only shrink the mask, so test the outer bounds always ...
        assert xs.min() >= np.ceil(lo_x - 1e-6) and xs.max() <= np.floor(hi_x + 1e-6), (b.name, lo_x, hi_x, xs.min(), xs.max())
        assert ys.min() >= np.ceil(lo_y - 1e-6) and ys.max() <= np.floor(hi_y + 1e-6), (b.name, lo_y, hi_y, ys.min(), ys.max())
        checked["boxes"] = checked.get("boxes", 0) + 1


def test_little_motion_camera_sees_the_action_only_at_the_border():
    s = make_scene(SceneConfig(cameras=3, moving=0, seconds=2.0, little_motion=1, seed=2))
    seen = {}
    for cam in s.cameras:
        T = cam.cam_from_world()
        xy, _ = observe_points(s.world, cam, cam.global_times_s, T)
        seen[cam.role] = seen.get(cam.role, []) + [np.isfinite(xy[..., 0]).mean()]
        if cam.role == "little_motion":
            x = xy[..., 0][np.isfinite(xy[..., 0])]
            # what it sees lies in the outer third of the image
            assert np.median(np.abs(x - cam.width / 2)) > cam.width / 6
    assert 0 < seen["little_motion"][0] < 0.8 * min(seen["static"])


def test_motion_blur_smears_moving_objects_only(tmp_path):
    """A static camera with an open shutter: pixels of the static set stay as they were, pixels
    near the fast thrown ball change (decoded from the written H.264 file)."""
    from dataclasses import replace

    from vs_inspect.io.video import open_video, read_frames
    from vs_inspect.synth.render import SceneRenderer
    from vs_inspect.synth.videos import render_camera

    scene = make_scene(SceneConfig(cameras=2, moving=0, seconds=1.0, width=128, height=96, seed=1))
    cam = scene.cameras[0]
    cam = replace(cam, timestamps_s=cam.timestamps_s[:3])
    frames = {}
    with SceneRenderer(scene.world, cam.width, cam.height) as r:
        for frac in (0.0, 0.9):
            c = replace(cam, motion_blur_frac=frac)
            render_camera(r, scene, c, tmp_path / f"blur{frac}.mp4", crf=12, progress=False)
            src = open_video(tmp_path / f"blur{frac}.mp4")
            frames[frac] = read_frames(src, [1])[0].astype(float)
    with SceneRenderer(scene.world, cam.width, cam.height, segmentation=True) as r:
        seg, _ = r.render(cam.global_times_s[1], cam.K, cam.cam_from_world())
    moving = np.zeros(seg.shape[:2], bool)
    for b in scene.world.bodies:
        if b.moving:
            moving |= np.all(seg == np.array(b.id_rgb), axis=2)
    near_moving = cv2.dilate(moving.astype(np.uint8), np.ones((9, 9), np.uint8)) > 0
    diff = np.abs(frames[0.9] - frames[0.0]).mean(axis=2)
    assert near_moving.any() and (~near_moving).any()
    assert diff[~near_moving].mean() < 2.0  # static set: only compression noise
    assert diff[moving].mean() > 2 * diff[~near_moving].mean() + 1.5  # measured 5.1 vs 0.9


def test_arc_option_spreads_cameras_over_the_arc():
    s = make_scene(SceneConfig(cameras=4, moving=1, seconds=1.0, arc_deg=60.0, seed=0))
    ang = []
    for cam in s.cameras:
        T = cam.cam_from_world()
        T = T[0] if T.ndim == 3 else T
        C = -T[:3, :3].T @ T[:3, 3]
        ang.append(np.arctan2(C[1], C[0]))
    ang = np.unwrap(np.array(ang))
    spread = np.rad2deg(ang.max() - ang.min())
    assert 40 < spread < 80, spread
    with pytest.raises(ValueError, match="arc_deg"):
        SceneConfig(arc_deg=0.0)


def test_same_length_changes_only_the_lengths(tmp_path):
    import dataclasses
    import json

    from vs_inspect.synth.videos import rendered_with

    cfg = dataclasses.replace(TINY, fps=None)
    a, b = make_scene(cfg), make_scene(dataclasses.replace(cfg, same_length=True))
    assert any(c.timestamps_s[-1] < 0.95 * cfg.seconds for c in a.cameras[1:])  # shorter by default
    for ca, cb in zip(a.cameras, b.cameras):
        assert cb.timestamps_s[-1] > cfg.seconds - 1.0 / cb.fps  # every video lasts `seconds`
        assert (ca.offset_s, ca.fps) == (cb.offset_s, cb.fps)  # the rest of the scene is the same
        np.testing.assert_array_equal(ca.K, cb.K)
        pa, pb = ca.cam_from_world(), cb.cam_from_world()  # (T,4,4): b has more frames
        np.testing.assert_array_equal(pa, pb[:len(pa)])
    # a scene cached before the field existed (its config without it) still counts as rendered
    (tmp_path / "COMPLETE").write_text("{}")
    old = {k: v for k, v in dataclasses.asdict(cfg).items() if k != "same_length"}
    (tmp_path / "scene.json").write_text(json.dumps({"config": old}))
    assert rendered_with(tmp_path, cfg)
    assert not rendered_with(tmp_path, dataclasses.replace(cfg, same_length=True))
