"""Where the cameras of a run are, as one number or one viewpoint: the scale of the scene they
span and a 3D view's eye that frames them all. Numbers only: no rerun here."""

from __future__ import annotations

import numpy as np

from ..types import CameraTrack

Eye = tuple[list[float], list[float], list[float]]  # (position, look target, up), world coordinates


def scene_scale(cams: dict[str, CameraTrack]) -> float:
    """Median distance of the cameras (a moving one by its mean centre, so that its many frames
    do not outvote the others) from their mean, world units; 1.0 for fewer than two cameras."""
    C = []
    for cam in cams.values():
        c = cam.centers()
        c = c[np.isfinite(c).all(1)]
        if len(c):
            C.append(c.mean(0))
    if len(C) < 2:
        return 1.0
    C = np.array(C)
    return float(np.median(np.linalg.norm(C - C.mean(0), axis=1))) or 1.0


def eye_behind(cams: dict[str, CameraTrack]) -> Eye | None:
    """A 3D view behind and above the cameras, looking where they look, so that all frustums and
    what they see are in view (a viewer's default eye frames the bounding box of everything, which
    a few far triangulated points make tiny). None without a camera or a defined up or forward."""
    C, fwd, up = [], [], []
    for cam in cams.values():
        T = cam.cam_from_world.reshape(-1, 4, 4)
        c = cam.centers()
        ok = np.isfinite(c).all(1)
        if not ok.any():
            continue
        R = T[ok][:, :3, :3]
        C.append(c[ok].mean(0))
        fwd.append(R[:, 2, :].mean(0))  # camera z (forward) in world coordinates
        up.append(-R[:, 1, :].mean(0))  # camera y points down
    if len(C) < 1:
        return None
    C, f, u = np.array(C), np.mean(fwd, 0), np.mean(up, 0)
    if np.linalg.norm(u) < 1e-6:
        return None
    u = u / np.linalg.norm(u)
    centre = C.mean(0)
    spread = max(float(np.linalg.norm(C - centre, axis=1).max()), 1e-3)
    facing = float(np.linalg.norm(f))  # ~1: cameras look the same way; ~0: they look inward
    if facing < 0.5:  # a ring of cameras: look at its centre, from outside and above
        f = fwd[0]
    f = f - np.dot(f, u) * u
    if np.linalg.norm(f) < 1e-6:
        return None
    f = f / np.linalg.norm(f)
    target = centre + (f * spread if facing >= 0.5 else 0.0)
    position = target - f * 2.0 * spread + u * 1.2 * spread
    return tuple(map(lambda x: [float(v) for v in x], (position, target, u)))
