"""The 3D scene, rendered off-screen with pyvista (EGL): camera frustums coloured per video (the
path of a moving camera), the static reconstruction, and triangulated trajectories coloured by time.
"""

from __future__ import annotations

import math
import os
import tempfile
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


def render_scene(data: ReportData, path: Path, size: tuple[int, int], dpi: float = 200.0,
                 formats: tuple[str, ...] = ("png",)) -> Path:
    """The 3D scene in a figure of size (px at dpi): the off-screen render (cameras with their
    labels, points, trajectories) as a picture, and its title, colour bar and names drawn by
    matplotlib, so that in PDF and SVG they are text (the figures' fonts and sizes)."""
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors as mcolors

    from .figure_layout import _finish, _save, size_of_width
    from .figure_style import FONT_PT, LINE_IN, _chars, _wrap

    w_in, h_in = size[0] / dpi, size[1] / dpi
    title = _title(data)
    bar = bool(data.trajectories)
    fig = plt.figure(figsize=(w_in, h_in), dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(1, 2, width_ratios=[1, 0.035]) if bar else fig.add_gridspec(1, 1)
    ax = fig.add_subplot(grid[0, 0])
    fig.suptitle(_wrap(title, _chars(w_in, FONT_PT)), fontsize=FONT_PT)
    _finish(fig, data, size_of_width(w_in))
    # the picture at about the size it is shown (labels stay near 8 pt)
    text_in = 0.18 * (title.count("\n") + 2) + LINE_IN * len(data.label_legend() and [1] or [])
    render_px = (max(64, int((w_in - (0.75 if bar else 0.1)) * dpi)), max(64, int((h_in - text_in) * dpi)))
    with tempfile.TemporaryDirectory(prefix="vs-inspect-3d-") as tmp:
        png = _render_png(data, Path(tmp) / "scene.png", render_px, dpi / 72.0)
        img = plt.imread(png)
    ax.imshow(img, interpolation="antialiased")
    ax.set_axis_off()
    if bar:
        lo, hi, n_labels, dec = nice_ticks(*_time_range(data))
        cb = fig.colorbar(cm.ScalarMappable(mcolors.Normalize(lo, hi), "viridis"), cax=fig.add_subplot(grid[0, 1]))
        cb.set_ticks(np.linspace(lo, hi, n_labels))
        cb.ax.yaxis.set_major_formatter(f"{{x:.{dec}f}}")
        cb.set_label("global time [s]", fontsize=FONT_PT)
    return _save(fig, path, dpi, formats)


def _title(data: ReportData) -> str:
    n_traj = len(data.trajectories)
    n_moving = sum(c.is_moving for c in data.cameras)
    title = f"3D scene: {len(data.cameras)} cameras" + \
            (f" ({n_moving} moving, with {'its' if n_moving == 1 else 'their'} path)" if n_moving else "") + \
            f", {n_traj} trajectories triangulated at the solved offsets, coloured by global time"
    if data.static_points is not None and len(data.static_points):
        title += f"; {len(data.static_points)} static points"
    return title


def _time_range(data: ReportData) -> tuple[float, float]:
    times = np.concatenate([t.time_s for t in data.trajectories])
    return float(np.nanmin(times)), float(np.nanmax(times))


def _render_png(data: ReportData, path: Path, size: tuple[int, int], px_per_pt: float) -> Path:
    import pyvista as pv

    from .figure_style import video_colors

    colors = video_colors(data.names or [c.name for c in data.cameras])
    zoom = px_per_pt  # text and line sizes below are in points at the printed size
    scale = _scene_scale(data)
    signals.checkpoint()  # VTK's rendering below cannot be stopped halfway
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        _draw(pl, pv, data, colors, zoom, scale)
        signals.checkpoint()
        pl.screenshot(str(path))
    finally:
        pl.close()
    signals.checkpoint()
    return path


def _draw(pl, pv, data: ReportData, colors, zoom: float, scale: float) -> None:
    pl.set_background("white")
    for cam in data.cameras:
        col = colors.get(cam.name, (0.3, 0.3, 0.3))
        pl.add_mesh(_camera_mesh(pv, cam, 0.08 * scale), color=col, line_width=max(1.0, 0.9 * zoom))
        C = cam.centers()
        if cam.is_moving:
            pl.add_mesh(pv.lines_from_points(C), color=col, line_width=max(1.0, 1.2 * zoom))
        pl.add_point_labels(C[:1] + np.array([0, 0, (0.15 if cam.is_moving else 0.06) * scale]),
                            [data.label(cam.name)], font_size=int(8 * zoom),
                            text_color=col, shape=None, show_points=False, bold=True,
                            always_visible=True)
    if data.static_points is not None and len(data.static_points):
        cloud = pv.PolyData(np.asarray(data.static_points, float))
        if data.static_colors is not None:
            cloud["rgb"] = np.asarray(data.static_colors, np.uint8)
            pl.add_mesh(cloud, scalars="rgb", rgb=True, point_size=max(1.0, 1.2 * zoom),
                        render_points_as_spheres=False)
        else:
            pl.add_mesh(cloud, color="#888888", point_size=max(1.0, 1.2 * zoom))
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
        lo, hi, _, _ = nice_ticks(float(np.nanmin(times)), float(np.nanmax(times)))
        pl.add_mesh(poly, scalars="global time [s]", cmap="viridis", line_width=1.2 * zoom,
                    clim=(lo, hi), show_scalar_bar=False)
    # an oblique view from above, fitted to everything drawn
    pl.view_vector((0.55, -0.75, 0.75), viewup=(0.0, 0.0, 1.0))
    pl.reset_camera()
    pl.camera.zoom(1.3)
