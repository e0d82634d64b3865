"""Render a synth Scene into H.264 videos plus its exact ground truth (one folder per scene).

Folder layout (`render_scene(scene, out)`):

    cam0.mp4 ...          H.264 videos, each frame with its presentation time (VFR kept)
    gt.json               {"offsets_s": {...}} (DESIGN.md convention; cam0 = 0)
    calibration.json      {"cam0": {"K", "dist", "cam_from_world" (4x4, or list of 4x4 per frame
                          for a moving camera), "size"}}
    trajectories.npz      true 3D trajectories on a global time grid (see write_trajectories)
    scene.json            config, cameras (file, size, fps/timestamps, offset, role, look), timings
    bundle/               the TRUE cue bundle (v1): exact cameras, projected surface points,
                          exact track pairs, gt.json
    COMPLETE              written last: the folder is finished (used for caching)

Visibility of a tracked surface point in a frame: inside the image, in front of the camera,
facing it (normal towards the camera), and not occluded: its depth is at most the rendered depth
at its pixel plus a tolerance (the depth map comes from the same render as the image).
"""

from __future__ import annotations

import json
import logging
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..io.bundle import write_bundle
from ..io.atomic import atomic_path, write_json_atomic, write_text_atomic
from ..io.video import VideoWriter
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo
from .world import CameraSpec, Scene, make_scene, observe_points

log = logging.getLogger(__name__)

COMPLETE = "COMPLETE"
OCCLUSION_TOL_M = 0.03  # absolute part of the depth tolerance of the occlusion test
OCCLUSION_TOL_REL = 0.01  # relative part (of the point's depth)
BLUR_SAMPLES = 5  # renders averaged per frame when the camera has motion blur
TRAJECTORY_HZ = 120.0  # rate of the written true 3D trajectories


def is_complete(folder: Path) -> bool:
    return (Path(folder) / COMPLETE).is_file()


def rendered_with(folder: Path, config) -> bool:
    """Whether folder holds a finished scene rendered with this SceneConfig (so it can be reused)."""
    if not is_complete(folder):
        return False
    try:
        cached = json.loads((Path(folder) / "scene.json").read_text()).get("config")
    except (OSError, ValueError):
        return False
    # a scene cached before a SceneConfig field existed was rendered with its default
    defaults = json.loads(json.dumps(asdict(type(config)())))
    return isinstance(cached, dict) and {**defaults, **cached} == json.loads(json.dumps(asdict(config)))


def render_unless_cached(folder: Path, config, progress: bool = True) -> bool:
    """Render the scene of this SceneConfig into folder unless a finished rendering of it is there
    (rendered_with). Returns True if it rendered."""
    if rendered_with(folder, config):
        return False
    render_scene(make_scene(config), folder, progress=progress)
    return True


def apply_look(rgb: np.ndarray, cam: CameraSpec) -> np.ndarray:
    """Exposure gain and white balance in linear light (gamma 2.2), back to uint8."""
    if cam.exposure_gain == 1.0 and cam.white_balance == (1.0, 1.0, 1.0):
        return rgb
    lin = (rgb.astype(np.float32) / 255.0) ** 2.2
    lin *= cam.exposure_gain * np.asarray(cam.white_balance, np.float32)
    return (np.clip(lin, 0, 1) ** (1 / 2.2) * 255 + 0.5).astype(np.uint8)


def visible(xy: np.ndarray, depth_pts: np.ndarray, depth_map: np.ndarray) -> np.ndarray:
    """(M,) bool: projected points (M,2) px with depth (M,) not hidden behind the depth map."""
    ok = np.isfinite(xy[:, 0])
    H, W = depth_map.shape
    col = np.clip(np.round(np.nan_to_num(xy[:, 0])).astype(int), 0, W - 1)
    row = np.clip(np.round(np.nan_to_num(xy[:, 1])).astype(int), 0, H - 1)
    d = depth_map[row, col]
    return ok & (depth_pts <= d + OCCLUSION_TOL_M + OCCLUSION_TOL_REL * depth_pts)


def render_camera(renderer, scene: Scene, cam: CameraSpec, path: Path, crf: int = 20,
                  progress: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Render one camera's video to path; return ((M,T,2) visible projections, (T,4,4) poses)."""
    renderer.set_size(cam.width, cam.height)
    g = cam.global_times_s
    poses = cam.pose_fn(g)
    xy_all, depth_all = observe_points(scene.world, cam, g, poses)
    dt = np.diff(cam.timestamps_s).min() if cam.num_frames > 1 else 1 / 30
    fps = cam.fps or float(1.0 / np.median(np.diff(cam.timestamps_s)))
    # frames are encoded on a worker thread (libx264 runs without the GIL) while the next renders
    with VideoWriter(path, cam.width, cam.height, fps, crf=crf) as writer, \
            ThreadPoolExecutor(max_workers=1) as pool:
        pending: deque = deque()
        for k in tqdm(range(cam.num_frames), desc=f"render {cam.name}", unit="frame",
                      disable=not progress, leave=False):
            rgb, dmap = renderer.render(g[k], cam.K, poses[k], depth=True)
            if cam.motion_blur_frac > 0:
                acc, n = rgb.astype(np.float32), 1
                shutter = cam.motion_blur_frac * dt
                for s in np.linspace(-0.5, 0.5, BLUR_SAMPLES):
                    if s == 0:  # the frame's own moment is already rendered
                        continue
                    gs = g[k] + s * shutter
                    T = cam.pose_fn(np.array([gs]))[0]
                    acc += renderer.render(gs, cam.K, T, depth=False)[0]
                    n += 1
                rgb = (acc / n + 0.5).astype(np.uint8)
            vis = visible(xy_all[:, k], depth_all[:, k], dmap)
            xy_all[~vis, k] = np.nan
            bgr = np.ascontiguousarray(apply_look(rgb, cam)[:, :, ::-1])
            pending.append(pool.submit(writer.write, bgr, float(cam.timestamps_s[k])))
            while len(pending) > 4:
                pending.popleft().result()
        while pending:
            pending.popleft().result()
    return xy_all, poses


def _video_info(cam: CameraSpec) -> VideoInfo:
    if cam.fps:
        return VideoInfo.constant_rate(cam.name, cam.width, cam.height, cam.num_frames, cam.fps)
    return VideoInfo(cam.name, cam.width, cam.height, cam.num_frames, cam.timestamps_s, None)


def true_bundle(scene: Scene, observations: dict[str, np.ndarray], poses: dict[str, np.ndarray],
                min_frames: int = 2) -> CueBundle:
    """The exact cue bundle: one track per tracked surface point seen in at least min_frames
    frames, and for every pair of videos the track pairs of the points both see."""
    inst = scene.world.track_instance
    videos, cameras, tracks, keep = [], {}, {}, {}
    for cam in scene.cameras:
        xy = observations[cam.name]
        rows = np.flatnonzero(np.isfinite(xy[..., 0]).sum(1) >= min_frames)
        keep[cam.name] = rows
        videos.append(_video_info(cam))
        cameras[cam.name] = CameraTrack(cam.K, poses[cam.name] if cam.moving else poses[cam.name][0])
        tracks[cam.name] = Tracks(xy[rows].astype(np.float32), inst[rows])
    pairs = {}
    names = [c.name for c in scene.cameras]
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            common, ia, ib = np.intersect1d(keep[a], keep[b], return_indices=True)
            if len(common):
                pairs[(a, b)] = TrackPairs(a, b, np.stack([ia, ib], 1))
    return CueBundle(tuple(videos), cameras, tracks, pairs, scene.offsets_s)


def write_trajectories(scene: Scene, path: Path) -> None:
    """trajectories.npz: times_global_s (G,), points_world (M,G,3) m, point_instance (M,),
    point_body (M,), body_names (B,), body_poses (B,G,4,4) world_from_body, object_names (O,)."""
    g0, g1 = scene.global_span_s()
    g = np.arange(g0, g1 + 1e-9, 1.0 / TRAJECTORY_HZ)
    X, _ = scene.world.points_at(g)
    w = scene.world
    moving = [i for i, b in enumerate(w.bodies) if b.moving]
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez_compressed(tmp, times_global_s=g, points_world=X.astype(np.float32),
                            point_instance=w.track_instance, point_body=w.track_body,
                            body_names=np.array([w.bodies[i].name for i in moving]),
                            body_index=np.array(moving),
                            body_poses=np.stack([w.bodies[i].world_from_body(g) for i in moving]),
                            object_names=np.array(w.object_names))


def calibration_dict(scene: Scene, poses: dict[str, np.ndarray]) -> dict:
    out = {}
    for cam in scene.cameras:
        T = poses[cam.name]
        out[cam.name] = {"K": cam.K.tolist(), "dist": [0.0] * 5,
                         "cam_from_world": T.tolist() if cam.moving else T[0].tolist(),
                         "size": [cam.width, cam.height]}
    return out


def scene_dict(scene: Scene, timings: dict) -> dict:
    cfg = asdict(scene.config)
    cams = []
    for c in scene.cameras:
        e = {"name": c.name, "file": f"{c.name}.mp4", "width": c.width, "height": c.height,
             "num_frames": c.num_frames, "offset_s": c.offset_s, "role": c.role, "moving": c.moving,
             "exposure_gain": c.exposure_gain, "white_balance": list(c.white_balance),
             "motion_blur_frac": c.motion_blur_frac}
        if c.fps:
            e["fps"] = c.fps
        else:
            e["timestamps_s"] = [float(t) for t in c.timestamps_s]
        cams.append(e)
    return {"format": "vs-inspect-synth-scene", "version": 1, "config": cfg, "cameras": cams,
            "objects": list(scene.world.object_names), "timings_s": timings}


def _remove_stale_videos(out: Path, keep: set[str]) -> None:
    """Delete the videos a previous scene.json in out lists that the new scene does not have."""
    try:
        old = json.loads((out / "scene.json").read_text())["cameras"]
    except (OSError, ValueError, KeyError, TypeError):
        return
    for cam in old:
        name = cam.get("file") if isinstance(cam, dict) else None
        if isinstance(name, str) and name not in keep and "/" not in name and name.endswith(".mp4"):
            (out / name).unlink(missing_ok=True)


def render_scene(scene: Scene, out: Path, crf: int = 20, progress: bool = True) -> dict:
    """Render every camera and write the videos and all ground truth to out. Returns timings."""
    from .render import SceneRenderer  # VTK only when rendering

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / COMPLETE).unlink(missing_ok=True)
    _remove_stale_videos(out, {f"{c.name}.mp4" for c in scene.cameras})
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    first = scene.cameras[0]
    obs, poses = {}, {}
    renderer = SceneRenderer(scene.world, first.width, first.height)
    try:
        timings["setup_s"] = round(time.perf_counter() - t0, 3)
        for cam in scene.cameras:
            t1 = time.perf_counter()
            obs[cam.name], poses[cam.name] = render_camera(renderer, scene, cam, out / f"{cam.name}.mp4",
                                                           crf=crf, progress=progress)
            timings[f"render_{cam.name}_s"] = round(time.perf_counter() - t1, 3)
            log.info("%s: %d frames in %.1f s", cam.name, cam.num_frames, time.perf_counter() - t1)
    finally:
        renderer.close()
    timings["render_total_s"] = round(time.perf_counter() - t0, 3)
    frames = sum(c.num_frames for c in scene.cameras)
    timings["frames"] = frames
    timings["frames_per_s"] = round(frames / timings["render_total_s"], 2)
    t2 = time.perf_counter()
    write_bundle(true_bundle(scene, obs, poses), out / "bundle", overwrite=True)
    write_json_atomic({"offsets_s": scene.offsets_s}, out / "gt.json")
    write_json_atomic(calibration_dict(scene, poses), out / "calibration.json")
    write_trajectories(scene, out / "trajectories.npz")
    timings["truth_s"] = round(time.perf_counter() - t2, 3)
    timings["total_s"] = round(time.perf_counter() - t0, 3)
    write_json_atomic(scene_dict(scene, timings), out / "scene.json")
    write_text_atomic(json.dumps({"frames": frames}) + "\n", out / COMPLETE)
    return timings
