"""The 3D scene, rendered off-screen with pyvista (EGL): camera frustums coloured per video (the
path of a moving camera), the static reconstruction, and triangulated trajectories coloured by time.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .. import signals
from ..geometry.point_cloud import frustum_lines
from .data import CameraView, ReportData

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")  # before vtk is imported

FRUSTUMS_PER_MOVING_CAMERA = 5


def _scene_scale(data: ReportData) -> float:
    c = np.concatenate([cam.centers() for cam in data.cameras]) if data.cameras else np.zeros((1, 3))
    ext = np.ptp(c, axis=0).max() if len(c) > 1 else 1.0
    return float(ext) if ext > 0 else 1.0


def _camera_mesh(pv, cam: CameraView, depth: float):
    F = cam.cam_from_world.shape[0]
    idx = [0] if F == 1 else np.unique(np.linspace(0, F - 1, FRUSTUMS_PER_MOVING_CAMERA).round().astype(int))
    pts_all, lines = [], []
    for j, f in enumerate(idx):
        K = cam.K if cam.K.ndim == 2 else cam.K[min(f, len(cam.K) - 1)]
        pts, segs = frustum_lines(K, cam.cam_from_world[f], cam.width, cam.height, depth)
        base = 5 * j
        pts_all.append(pts)
        for s0, s1 in segs:
            lines += [2, base + s0, base + s1]
    return pv.PolyData(np.vstack(pts_all), lines=np.array(lines))


def nice_ticks(lo: float, hi: float, max_ticks: int = 6) -> tuple[float, float, int, int]:
    """Round colour-bar limits: (lo', hi', number of labels, decimals) with lo' <= lo, hi' >= hi
    and labels at a step of 1, 2 or 5 times a power of ten."""
    span = max(hi - lo, 1e-9)
    raw = span / max(1, max_ticks - 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw - 1e-12)
    lo2, hi2 = math.floor(lo / step + 1e-9) * step, math.ceil(hi / step - 1e-9) * step
    if hi2 <= lo2:
        hi2 = lo2 + step
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    return lo2, hi2, round((hi2 - lo2) / step) + 1, decimals


def _title_lines(text: str, width: int) -> str:
    import textwrap
    return "\n".join(textwrap.wrap(text, width))


def render_scene(data: ReportData, path: Path, size: tuple[int, int], dpi: float = 100.0,
                 formats: tuple[str, ...] = ("png",)) -> Path:
    """The 3D scene as a PNG of size (px, already at dpi: fonts scale by dpi/100); PDF and SVG
    embed that picture."""
    png = _render_png(data, Path(path).with_suffix(".png"), size, dpi / 100.0)
    out = [png] if "png" in formats else []
    for fmt in formats:
        if fmt == "png":
            continue
        signals.checkpoint()  # between files
        import matplotlib.pyplot as plt
        img = plt.imread(png)
        fig = plt.figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        fig.figimage(img, resize=False)
        p = Path(path).with_suffix("." + fmt)
        fig.savefig(p, format=fmt, dpi=dpi, metadata={"pdf": {"CreationDate": None},
                                                     "svg": {"Date": None}}.get(fmt))
        plt.close(fig)
        out.append(p)
    if "png" not in formats:
        png.unlink()
    return out[0]


def _render_png(data: ReportData, path: Path, size: tuple[int, int], scale: float) -> Path:
    import pyvista as pv

    from .figures import video_colors

    colors = video_colors(data.names or [c.name for c in data.cameras])
    zoom = scale  # font scale with the dpi
    scale = _scene_scale(data)
    signals.checkpoint()  # VTK's rendering below cannot be stopped halfway
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        _draw(pl, pv, data, colors, zoom, scale, size)
        signals.checkpoint()
        pl.screenshot(str(path))
    finally:
        pl.close()
    signals.checkpoint()
    return path


def _draw(pl, pv, data: ReportData, colors, zoom: float, scale: float, size: tuple[int, int]) -> None:
    pl.set_background("white")
    centers_all = []
    for cam in data.cameras:
        col = colors.get(cam.name, (0.3, 0.3, 0.3))
        pl.add_mesh(_camera_mesh(pv, cam, 0.08 * scale), color=col, line_width=3)
        C = cam.centers()
        centers_all.append(C)
        if cam.is_moving:
            pl.add_mesh(pv.lines_from_points(C), color=col, line_width=5)
        pl.add_point_labels(C[:1] + np.array([0, 0, (0.15 if cam.is_moving else 0.06) * scale]), [cam.name],
                            font_size=int(22 * zoom),
                            text_color=col, shape=None, show_points=False, bold=True,
                            always_visible=True)
    if data.static_points is not None and len(data.static_points):
        cloud = pv.PolyData(np.asarray(data.static_points, float))
        if data.static_colors is not None:
            cloud["rgb"] = np.asarray(data.static_colors, np.uint8)
            pl.add_mesh(cloud, scalars="rgb", rgb=True, point_size=3, render_points_as_spheres=False)
        else:
            pl.add_mesh(cloud, color="#888888", point_size=3)
    if data.trajectories:
        pts = np.concatenate([t.points_world for t in data.trajectories])
        times = np.concatenate([t.time_s for t in data.trajectories])
        lines, base = [], 0
        for t in data.trajectories:
            n = len(t.points_world)
            lines += [n] + list(range(base, base + n))
            base += n
        poly = pv.PolyData(pts, lines=np.array(lines))
        poly["global time [s]"] = times
        lo, hi, n_labels, dec = nice_ticks(float(np.nanmin(times)), float(np.nanmax(times)))
        pl.add_mesh(poly, scalars="global time [s]", cmap="viridis", line_width=3.5 * zoom,
                    clim=(lo, hi),
                    scalar_bar_args=dict(title="global time [s]", title_font_size=int(22 * zoom),
                                         label_font_size=int(18 * zoom), color="black", vertical=True,
                                         position_x=0.88, position_y=0.25, width=0.05, height=0.5,
                                         n_labels=n_labels, fmt=f"%.{dec}f"))
    # an oblique view from above, fitted to everything drawn
    pl.view_vector((0.55, -0.75, 0.75), viewup=(0.0, 0.0, 1.0))
    pl.reset_camera()
    pl.camera.zoom(1.3)
    n_traj = len(data.trajectories)
    n_moving = sum(c.is_moving for c in data.cameras)
    title = f"3D scene: {len(data.cameras)} cameras" + \
            (f" ({n_moving} moving, with {'its' if n_moving == 1 else 'their'} path)" if n_moving else "") + \
            f", {n_traj} trajectories triangulated at the solved offsets, coloured by global time"
    if data.static_points is None:
        title += "; no static reconstruction in the input"
    # wrapped to the window's width, placed with a margin: nothing runs off an edge
    pl.add_text(_title_lines(title, int(size[0] / (15.0 * zoom))), position=(int(12 * zoom), size[1] - int(70 * zoom)),
                font_size=int(13 * zoom), color="black")
