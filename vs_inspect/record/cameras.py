"""The 3D world of the recording: each camera's pinhole and pose (a frustum, in the camera's
colour), a moving camera's path and its pose per frame, a label at each camera's centre, and the
static points Stage 0 reconstructed.

Entities: world/cameras/<v> (Pinhole, Transform3D), world/cameras/<v>/trail, the camera labels
and world/points (io/recording_paths.py).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from ..analysis.camera_layout import Eye, eye_behind, scene_scale
from ..io.recording_paths import WORLD_POINTS, camera_labels_path, camera_path, camera_trail_path
from ..types import CameraTrack, VideoInfo
from .context import RecordingContext
from .style import at_offset_ms
from .videos import time_indexes

FRUSTUM_SCALE = 0.3  # frustum depth as a share of the cameras' spread around their median


class CameraLog:
    """The cameras' part of the recording."""

    def __init__(self, ctx: RecordingContext):
        self.ctx = ctx
        self.logged: set[str] = set()  # videos whose camera is in the 3D view
        self.eye: Eye | None = None  # 3D view's (position, look target, up), world

    def log_points(self, points_world: np.ndarray | None, colors: np.ndarray | None) -> None:
        """The static 3D points (N,3) with their (N,3) uint8 colours."""
        if points_world is not None and len(points_world):
            pts = np.asarray(points_world, dtype=np.float32)
            cols = np.asarray(colors, dtype=np.uint8) if colors is not None else None
            self.ctx.rec.log(WORLD_POINTS, rr.Points3D(pts, colors=cols, radii=rr.Radius.ui_points(1.5)),
                             static=True)

    def log_static(self, cams: dict[str, CameraTrack], videos: list[VideoInfo]) -> None:
        """Pinhole and (static) pose of each camera, once per camera; a labelled point at each
        camera's centre (the middle pose of a moving one), in the camera's colour."""
        if not cams:
            return
        depth = FRUSTUM_SCALE * scene_scale(cams)
        new = False
        for v in videos:
            cam = cams.get(v.name)
            if cam is None or v.name in self.logged:
                continue
            self.logged.add(v.name)
            new = True
            self._log_camera(v, cam, depth)
        if new:
            self.eye = eye_behind(cams)
            self._log_labels(cams)

    def _log_camera(self, v: VideoInfo, cam: CameraTrack, depth: float) -> None:
        rec, colour = self.ctx.rec, self.ctx.camera_color(v.name)
        base = camera_path(v.name)
        K0 = cam.K if cam.K.ndim == 2 else cam.K[0]
        rec.log(base, rr.Pinhole(image_from_camera=K0, resolution=[v.width, v.height],
                                 camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=depth,
                                 color=colour, line_width=rr.Radius.ui_points(1.5)), static=True)
        if not cam.is_moving:
            T = cam.cam_from_world
            rec.log(base, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3],
                                         relation=rr.TransformRelation.ChildFromParent), static=True)
        else:
            C = cam.centers()
            rec.log(camera_trail_path(v.name),
                    rr.LineStrips3D([C[np.isfinite(C).all(1)].astype(np.float32)], colors=[colour],
                                    radii=rr.Radius.ui_points(1.5), labels=[f"{self.ctx.short(v.name)} path"]),
                    static=True)

    def _log_labels(self, cams: dict[str, CameraTrack]) -> None:
        names = [n for n in self.logged if n in cams]
        centres, labels, colors = [], [], []
        for n in sorted(names, key=lambda n: list(cams).index(n)):
            C = cams[n].centers()
            C = C[np.isfinite(C).all(1)]
            if len(C):
                centres.append(C[len(C) // 2])
                labels.append(self.ctx.short(n))
                colors.append(self.ctx.camera_color(n))
        if centres:
            self.ctx.rec.log(camera_labels_path(), rr.Points3D(np.array(centres, dtype=np.float32), labels=labels,
                                                               colors=colors, radii=rr.Radius.ui_points(4.0),
                                                               show_labels=True), static=True)

    def log_moving(self, offsets: dict[str, float | None]) -> None:
        """Each moving camera's pose per frame (on `frame`, and on `time` at its video's offset),
        and its middle pose on offset_ms, so that the 3D view is not empty where the viewer opens."""
        ctx = self.ctx
        cams = ctx.cameras()
        for name, buf in ctx.videos.items():
            cam = cams.get(name)
            if cam is None or not cam.is_moving:
                continue
            n = cam.num_pose_frames
            frames = np.arange(n)
            T = cam.pose_at(frames)
            ctx.rec.send_columns(camera_path(name), time_indexes(buf.info, frames, offsets.get(name)),
                                 rr.Transform3D.columns(translation=T[:, :3, 3], mat3x3=T[:, :3, :3],
                                                        relation=[rr.TransformRelation.ChildFromParent] * n))
            if ctx.offset_ms_min is not None:
                Tm = T[n // 2]
                with at_offset_ms(ctx.rec, ctx.offset_ms_min):
                    ctx.rec.log(camera_path(name), rr.Transform3D(
                        translation=Tm[:3, 3], mat3x3=Tm[:3, :3], relation=rr.TransformRelation.ChildFromParent))
