"""Teach the epipolar synchronization cue on a tiny two-camera scene, step by step.

    python examples/teach_epipolar_cue.py --out out/teach

Writes, into --out:
  step1_geometry.png   two static cameras and one moving point: where it is in each image
  step2_cue.png        b's point at time t gives a line in a; a's point lies on it only at the right Δ
  step3_search.png     the offset search: the energy E(Δ) over all candidate offsets, its minimum
  step4_plane.png      in 3D: the two cameras, the moving point and the epipolar plane through all
                       three; b's view (its point, the epipole of a) and a's view (the plane's line)
  step5_ambiguity.png  one point at one moment is not enough: a's track crosses b's line twice,
                       so two offsets fit; averaging over all points and frames leaves one minimum
  step6_sweep.gif      an animated sweep of Δ: a's points slide along their tracks and meet b's
                       lines at the true offset, where the animation pauses, while the energy
                       E(Δ) is traced (also step6_sweep.mp4 when ffmpeg is on PATH)
  steps.json           the one moment of b every step shows, and the offsets of the sweep's frames
  report/              the standard report (3D scene, landscape, graph, timeline, epipolar panel)
  teach.rrd            the recording: open it with `rerun teach.rrd` and scrub the `offset_ms`
                       timeline under pairs/cam0__cam1/epipolar to watch the lines meet the points

Conventions (DESIGN.md): a frame at local time τ of video v shows global time τ + offset(v), and
Δ_ab = offset(b) − offset(a), so x_a(t + Δ) and x_b(t) show the same moment.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np  # noqa: F401  (before anything that may import pycolmap)

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from vs_inspect.geometry.epipolar import (camera_centers, epipolar_lines, epipolar_residual,  # noqa: E402
                                         fundamental_from_cameras, project)
from vs_inspect.geometry.triangulate import projection_matrix, triangulate_dlt  # noqa: E402
from vs_inspect.io.bundle import write_bundle  # noqa: E402
from vs_inspect.io.result import write_run_result  # noqa: E402
from vs_inspect.pipeline import run  # noqa: E402
from vs_inspect.report.build import render_report  # noqa: E402
from vs_inspect.analysis.report_data import report_data_from_run  # noqa: E402
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene  # noqa: E402
from vs_inspect.result_types import RunInputs  # noqa: E402

from vs_inspect import palette  # noqa: E402  (the recording's and the report's colours)

ACCEPT, REJECT = palette.hex_of(palette.ACCEPTED), palette.hex_of(palette.REJECTED)  # right / wrong Δ
A_COLOR, B_COLOR = (palette.hex_of(c) for c in palette.CAMERA[:2])  # the two cameras
SCENE = CueSceneConfig(cameras=2, moving=0, variable_rate=0, seconds=6.0, max_offset_s=1.5,
                       noise_px=0.5, wrong_fraction=0.0, pose_error_deg=0.0, points_per_object=12,
                       pairs_per_view_pair=300, no_match_pairs=0, all_wrong_pair=False,
                       fps_choices=(25.0, 30.0), track_life_s=(6.0, 6.0), seed=4)


def sample(xy: np.ndarray, ts: np.ndarray, q: float) -> np.ndarray:
    """(N,2) track points at local time q (linear between frames, NaN outside)."""
    k = np.searchsorted(ts, q) - 1
    if k < 0 or k >= len(ts) - 1:
        return np.full((xy.shape[0], 2), np.nan)
    w = (q - ts[k]) / (ts[k + 1] - ts[k])
    return xy[:, k] + w * (xy[:, k + 1] - xy[:, k])


def px(sampson_px2: float) -> str:
    """A Sampson error as the distance it stands for (its square root), px, for people (the
    report's format)."""
    from vs_inspect.report.figure_style import fmt_px
    return fmt_px(float(np.sqrt(sampson_px2)) if np.isfinite(sampson_px2) else float("nan"))


def _frustum(ax, K: np.ndarray, T: np.ndarray, w: int, h: int, depth: float, color: str, name: str):
    """A camera as a pyramid: its centre and its image's corners at `depth` (world units)."""
    C = camera_centers(T)
    corners = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], float) @ np.linalg.inv(K).T
    world = (corners * depth - T[:3, 3]) @ T[:3, :3]  # Rᵀ (x − t)
    for p in world:
        ax.plot(*zip(C, p), color=color, lw=1.2)
    ax.plot(*np.vstack([world, world[:1]]).T, color=color, lw=1.5)
    ax.text(*C, f"  {name}", color=color, fontsize=11, fontweight="bold")
    return C


def step4_plane(path: Path, bundle, a: str, b: str, ia: int, ib: int, t_b: float, delta: float,
                x_b: np.ndarray, x_a: np.ndarray, F_ab: np.ndarray) -> Path:
    """3D: both cameras, the point's path, the epipolar plane (C_a, C_b, X); b's view; a's view."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    va, vb = bundle.video(a), bundle.video(b)
    ca, cb = bundle.cameras[a], bundle.cameras[b]
    Ka, Ta = ca.K.reshape(-1, 3, 3)[0], ca.cam_from_world.reshape(-1, 4, 4)[0]
    Kb, Tb = cb.K.reshape(-1, 3, 3)[0], cb.cam_from_world.reshape(-1, 4, 4)[0]
    Pa, Pb = projection_matrix(Ka, Ta), projection_matrix(Kb, Tb)
    X = triangulate_dlt(Pa, Pb, x_a, x_b)
    # the point's path: b's frames with a read at the same moment (t + Δ)
    path_b = bundle.tracks[b].xy[ib]
    path_a = np.stack([sample(bundle.tracks[a].xy[ia:ia + 1], va.timestamps_s, t + delta)[0]
                       for t in vb.timestamps_s])
    path3d = triangulate_dlt(Pa, Pb, path_a, path_b)
    Ca, Cb = camera_centers(Ta), camera_centers(Tb)
    base = float(np.linalg.norm(Ca - Cb))

    fig = plt.figure(figsize=(20, 6.8), dpi=100, layout="constrained")
    gs = fig.add_gridspec(1, 3, width_ratios=[1.35, 1, 1])
    ax3 = fig.add_subplot(gs[0], projection="3d")
    _frustum(ax3, Ka, Ta, va.width, va.height, 0.25 * base, A_COLOR, a)
    _frustum(ax3, Kb, Tb, vb.width, vb.height, 0.25 * base, B_COLOR, b)
    ok = np.isfinite(path3d[:, 0])
    ax3.plot(*path3d[ok].T, color="#333333", lw=2.0, label="the point's path")
    # the plane as a rectangle along the baseline u, reaching past X along v (⊥ u, in the plane)
    u = (Cb - Ca) / base
    v = (X - Ca) - np.dot(X - Ca, u) * u
    height = max(1.4 * np.linalg.norm(v), 0.3 * base)
    v = v / np.linalg.norm(v)
    s0, s1 = min(0.0, np.dot(X - Ca, u)) - 0.1 * base, max(base, np.dot(X - Ca, u)) + 0.1 * base
    quad = np.array([Ca + s0 * u - 0.15 * height * v, Ca + s1 * u - 0.15 * height * v,
                     Ca + s1 * u + height * v, Ca + s0 * u + height * v])
    ax3.add_collection3d(Poly3DCollection([quad], alpha=0.28, facecolor="#56B4E9", edgecolor="#0072B2"))
    for C, col in ((Ca, A_COLOR), (Cb, B_COLOR)):
        ax3.plot(*zip(C, X), color=col, lw=1.8, ls="--")
    ax3.plot(*zip(Ca, Cb), color="black", lw=1.5, label="baseline (through both epipoles)")
    ax3.scatter(*X, s=60, color="black", depthshade=False, label=f"X at global time of {b}'s t = {t_b:.2f} s")
    pts = np.vstack([Ca, Cb, X, path3d[ok], quad])
    mid, rad = 0.5 * (pts.min(0) + pts.max(0)), 0.5 * np.ptp(pts, axis=0).max()
    ax3.set(xlim=(mid[0] - rad, mid[0] + rad), ylim=(mid[1] - rad, mid[1] + rad),
            zlim=(mid[2] - rad, mid[2] + rad), xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
    # look at the plane obliquely from the side of its normal, so that it shows as a surface
    n = np.cross(u, v)
    n = n if n[2] >= 0 else -n
    d = 0.8 * n + 0.35 * v + 0.25 * u
    d /= np.linalg.norm(d)
    ax3.view_init(elev=max(20.0, float(np.degrees(np.arcsin(np.clip(d[2], -1, 1))))),
                  azim=float(np.degrees(np.arctan2(d[1], d[0]))))
    ax3.legend(loc="upper left", fontsize=8.5)
    ax3.set_title("3D: the epipolar plane holds both camera centres and the point X;\n"
                  "it cuts each image in a line (blue: the plane)", fontsize=11)

    # b's view: its point, the epipole (where b sees a's centre) and the plane's line in b
    axb = fig.add_subplot(gs[1])
    e_b = project(Kb, Tb, Ca)
    line_b = epipolar_lines(F_ab.T, x_a)
    axb.plot(path_b[:, 0], path_b[:, 1], color="#bbbbbb", lw=1.5, label=f"{b}'s track over time")
    axb.axline((0.0, -line_b[2] / line_b[1]), slope=-line_b[0] / line_b[1], color=A_COLOR, lw=2,
               label=f"line in {b} of {a}'s point at the same moment")
    axb.scatter(*x_b, s=110, color=B_COLOR, edgecolors="black", zorder=5, label=f"{b}'s point at t")
    inside = np.all(np.isfinite(e_b)) and 0 <= e_b[0] <= vb.width and 0 <= e_b[1] <= vb.height
    if inside:
        axb.scatter(*e_b, marker="x", s=90, color="black", label=f"epipole: {a}'s centre seen by {b}")
    axb.set(xlim=(0, vb.width), ylim=(vb.height, 0), xlabel="x [px]", ylabel="y [px]")
    axb.set_aspect("equal")
    axb.legend(loc="lower left", fontsize=8.5)
    axb.set_title(f"{b}'s view (whole image): b's point picks the plane"
                  + ("" if inside else f"\n(the epipole of {a} is outside the image)"), fontsize=11)

    # a's view: the same plane is a line through a's point at the right moment
    axa = fig.add_subplot(gs[2])
    line_a = F_ab @ np.array([x_b[0], x_b[1], 1.0])
    tr = bundle.tracks[a].xy[ia]
    axa.plot(tr[:, 0], tr[:, 1], color="#bbbbbb", lw=1.5, label=f"{a}'s track over time")
    axa.axline((0.0, -line_a[2] / line_a[1]), slope=-line_a[0] / line_a[1], color=B_COLOR, lw=2,
               label=f"line in {a} of {b}'s point")
    axa.scatter(*x_a, s=110, color=A_COLOR, edgecolors="black", zorder=5, label=f"{a}'s point at t + Δ")
    axa.set(xlim=(0, va.width), ylim=(va.height, 0), xlabel="x [px]", ylabel="y [px]")
    axa.set_aspect("equal")
    axa.legend(loc="lower left", fontsize=8.5)
    axa.set_title(f"{a}'s view (whole image): at the true Δ = {delta:+.3f} s\n"
                  "a's point lies on b's line", fontsize=11)
    fig.suptitle("Step 4. Why a line: the two camera centres and the point span a plane; each "
                 "camera sees that plane edge-on, as a line", fontsize=12)
    fig.savefig(path)
    plt.close(fig)
    return path


def _crossings(line: np.ndarray, xy: np.ndarray, ts: np.ndarray) -> np.ndarray:
    """Local times where a track (T,2) crosses a line (sign change of its signed distance,
    interpolated linearly between frames)."""
    d = (xy @ line[:2] + line[2]) / np.hypot(line[0], line[1])
    k = np.flatnonzero(np.isfinite(d[:-1]) & np.isfinite(d[1:]) & (np.sign(d[:-1]) != np.sign(d[1:])))
    w = d[k] / (d[k] - d[k + 1])
    return ts[k] + w * (ts[k + 1] - ts[k])


def step5_ambiguity(path: Path, bundle, a: str, b: str, F_ab: np.ndarray, delta: float, land,
                    k_ref: int) -> tuple[Path, int | None]:
    """A matched point whose track in a crosses b's line twice: two Δ fit that one observation.
    Looked for at the reference moment (b's frame k_ref), else at the nearest frame of b that has
    one. Returns (path, the frame of b shown, None when no track crosses its line twice)."""
    va, vb = bundle.video(a), bundle.video(b)
    xa, xb = bundle.tracks[a].xy, bundle.tracks[b].xy
    lo, hi = float(np.nanmin(land.offsets_s)), float(np.nanmax(land.offsets_s))
    best = None
    # the reference moment first, then ever farther from it
    order = sorted(range(0, vb.num_frames), key=lambda k: (abs(k - k_ref), k))
    for k in order:
        if best is not None and best[0] > 0:
            break  # the nearest moment with a clean double crossing
        for i, j in bundle.pair(a, b).index:
            if not np.isfinite(xb[j, k, 0]):
                continue
            line = F_ab @ np.array([xb[j, k, 0], xb[j, k, 1], 1.0])
            ds = _crossings(line, xa[i], va.timestamps_s) - vb.timestamps_s[k]
            ds = ds[(ds >= lo) & (ds <= hi)]
            if len(ds) == 2 and np.min(np.abs(ds - delta)) < 0.05:
                # a clean double crossing: the second one clearly apart in time (not at the
                # range's edge) and in the image (not noise jittering about the line)
                gap = float(np.max(np.abs(ds - delta)))
                p0, p1 = (sample(xa[i][None], va.timestamps_s, vb.timestamps_s[k] + d)[0] for d in ds)
                apart = float(np.linalg.norm(p0 - p1))
                score = apart if 0.3 <= gap <= 2.5 else 0.0
                if best is None or score > best[0]:
                    best = (score, i, j, k, line, ds)
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(17, 6), dpi=100, layout="constrained",
                                  width_ratios=[1, 1.25])
    if best is None:
        ax.text(0.5, 0.5, "no track in this scene crosses its line twice", ha="center",
                transform=ax.transAxes)
    else:
        _, i, j, k, line, ds = best
        t_b = float(vb.timestamps_s[k])
        tr = xa[i]
        ok = np.isfinite(tr[:, 0])
        sc = ax.scatter(tr[ok, 0], tr[ok, 1], c=va.timestamps_s[ok] - t_b, cmap="viridis", s=9,
                        label=f"{a}'s track; colour = Δ at which a shows it")
        fig.colorbar(sc, ax=ax, label="Δ = local time in a − t  [s]", shrink=0.8)
        ax.axline((0.0, -line[2] / line[1]), slope=-line[0] / line[1], color=B_COLOR, lw=2,
                  label=f"line of {b}'s point at t = {t_b:.2f} s")
        for n, d in enumerate(sorted(ds)):
            p = sample(tr[None], va.timestamps_s, t_b + d)[0]
            true = abs(d - delta) < 0.05
            ax.scatter(*p, s=200, facecolors="none", edgecolors=ACCEPT if true else REJECT, lw=2.5,
                       zorder=5)
            ax.annotate(f"Δ = {d:+.2f} s" + (" (true)" if true else " (also fits!)"), p,
                        xytext=(14, 14) if n % 2 else (-14, -16), ha="left" if n % 2 else "right",
                        va="bottom" if n % 2 else "top", textcoords="offset points", fontsize=10,
                        color=ACCEPT if true else REJECT, fontweight="bold")
        pad = 60
        ax.set(xlim=(max(0, np.nanmin(tr[:, 0]) - pad), min(va.width, np.nanmax(tr[:, 0]) + pad)),
               ylim=(min(va.height, np.nanmax(tr[:, 1]) + pad), max(0, np.nanmin(tr[:, 1]) - pad)),
               xlabel="x [px]", ylabel="y [px]")
        ax.set_aspect("equal")
        ax.legend(loc="lower left", fontsize=9)
        when = ("the moment of steps 2, 4 and 6" if k == k_ref else
                f"the moment nearest steps 2, 4 and 6 ({float(vb.timestamps_s[k_ref]):.2f} s) with such a track")
        ax.set_title(f"one matched point at t = {t_b:.2f} s, {when}:\n{a}'s track crosses {b}'s line "
                     f"{len(ds)} times", fontsize=11)
        # the error of this one observation against Δ, and the energy over all of them
        grid = np.union1d(land.offsets_s, ds)  # the crossings themselves too: exact zeros
        x_b = xb[j, k]
        one = np.array([epipolar_residual(F_ab, sample(tr[None], va.timestamps_s, t_b + d)[0], x_b,
                                          "sampson") for d in grid], float)
        floor = 1e-2  # px: the log axis shows the zeros at the crossings as this floor
        ax2.plot(grid, np.maximum(np.sqrt(one), floor), color=REJECT, lw=1.4,
                 label="this one observation: its distance from the line (Sampson)")
        ax2.set_yscale("log")
        ax2.set_ylim(bottom=floor / 2)
        ax2.set_ylabel("distance of one observation from its line [px]", color=REJECT)
        for d in ds:
            ax2.axvline(d, color=ACCEPT if abs(d - delta) < 0.05 else REJECT, ls=":", lw=1.5)
        tw = ax2.twinx()
        tw.plot(land.offsets_s, land.energy, color=A_COLOR, lw=2, label="E(Δ): all points, all frames")
        tw.set_ylabel("energy over all observations", color=A_COLOR)
        ax2.axvline(delta, color="black", ls="--", lw=1.2)
        ax2.set_xlabel(f"Δ = offset({b}) − offset({a}) [s]")
        h1, l1 = ax2.get_legend_handles_labels()
        h2, l2 = tw.get_legend_handles_labels()
        ax2.legend(h1 + h2, l1 + l2, loc="lower left", fontsize=9, framealpha=0.95)
        ax2.set_title("one observation has a zero at every crossing; the average over all "
                      "points and frames\nhas one clear minimum (dashed: true Δ)", fontsize=11)
    fig.suptitle("Step 5. The two-crossings ambiguity: a curved track can meet the same line more "
                 "than once", fontsize=12)
    fig.savefig(path)
    plt.close(fig)
    return path, (None if best is None else int(best[3]))


FRAME_MS = 160  # the sweep's frames, ms each
PAUSE_MS = 2400  # how long the sweep rests at the true Δ


def step6_sweep(path: Path, bundle, a: str, b: str, F_ab: np.ndarray, delta: float, land, k: int,
                frames: int = 33) -> tuple[list[Path], list[float], list[int]]:
    """An animation: Δ sweeps across the true offset (one of its frames exactly), where it rests
    PAUSE_MS; b's lines (its points at the reference moment, frame k) stay, a's points slide.
    Returns (files written, the Δ of each frame, each frame's duration in ms)."""
    import shutil

    va, vb = bundle.video(a), bundle.video(b)
    xa, xb = bundle.tracks[a].xy, bundle.tracks[b].xy
    idx = bundle.pair(a, b).index
    t_b = float(vb.timestamps_s[k])
    seen = np.flatnonzero(np.isfinite(xb[idx[:, 1], k, 0]))
    pick = idx[seen[np.linspace(0, len(seen) - 1, min(12, len(seen))).round().astype(int)]]
    lines = epipolar_lines(F_ab, xb[pick[:, 1], k])
    deltas = delta + np.linspace(-0.8, 0.8, frames | 1)  # odd: the middle frame is the true Δ
    colors = plt.get_cmap("tab20")(np.arange(len(pick)) % 20)

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 4.8), dpi=80, layout="constrained",
                                  width_ratios=[1.25, 1])
    for l, c in zip(lines, colors):
        ax.axline((0.0, -l[2] / l[1]), slope=-l[0] / l[1], color=c, lw=1.2, alpha=0.8)
    for (i, _), c in zip(pick, colors):
        ax.plot(xa[i, :, 0], xa[i, :, 1], color=c, lw=0.6, alpha=0.35)
    dots = ax.scatter(np.zeros(len(pick)), np.zeros(len(pick)), s=70, c=colors, edgecolors="black", zorder=5)
    ax.set(xlim=(0, va.width), ylim=(va.height, 0), xlabel="x [px]", ylabel="y [px]")
    ax.set_aspect("equal")
    title = ax.set_title("", fontsize=11)
    ax2.plot(land.offsets_s, land.energy, color="#3b4cc0", lw=1.4)
    ax2.axvline(delta, color="black", ls="--", lw=1.0, label=f"true Δ = {delta:+.3f} s")
    cursor = ax2.axvline(deltas[0], color=REJECT, lw=2)
    ax2.set(xlim=(deltas[0] - 0.3, deltas[-1] + 0.3), xlabel="Δ [s]", ylabel="energy E(Δ)")
    ax2.legend(loc="upper right", fontsize=9)
    ax2.grid(True, alpha=0.3)
    fig.suptitle(f"Sweeping Δ: lines = {b}'s points at t = {t_b:.2f} s; dots = {a}'s matched "
                 "points at t + Δ (faint: their tracks)", fontsize=11)

    def draw(n: int):
        d = deltas[n]
        pts = np.stack([sample(xa[i:i + 1], va.timestamps_s, t_b + d)[0] for i in pick[:, 0]])
        dots.set_offsets(np.nan_to_num(pts, nan=-1e4))
        err = epipolar_residual(F_ab, pts, xb[pick[:, 1], k], "sampson")
        near = abs(d - delta) < 0.5 * (deltas[1] - deltas[0])
        cursor.set_xdata([d, d])
        cursor.set_color(ACCEPT if near else REJECT)
        title.set_text(f"Δ = {d:+.3f} s: median distance to the lines {px(float(np.nanmedian(err)))} px"
                       + ("  — the true Δ: on the lines" if near else ""))
        title.set_color(ACCEPT if near else "black")
        return dots, cursor, title

    # each frame drawn once, then written as GIF (Pillow) and, when ffmpeg is on PATH, as H.264
    # MP4 (what matplotlib's PillowWriter and FFMpegWriter do, without drawing every frame twice)
    from PIL import Image
    fig.canvas.draw()
    fig.set_layout_engine("none")  # the layout is fixed now: no re-layout on every frame
    images = []
    for n in range(len(deltas)):
        draw(n)
        fig.canvas.draw()
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    pause = int(np.argmin(np.abs(deltas - delta)))
    durations = [PAUSE_MS if n == pause else FRAME_MS for n in range(len(deltas))]
    frames_pil = [Image.fromarray(im) for im in images]
    frames_pil[0].save(path, save_all=True, append_images=frames_pil[1:], duration=durations, loop=0)
    written = [path]
    if shutil.which("ffmpeg"):
        import subprocess
        h, w = images[0].shape[:2]
        mp4 = path.with_suffix(".mp4")
        fps = round(1000 / FRAME_MS)
        repeats = [max(1, round(d / FRAME_MS)) for d in durations]  # the pause as the same frame again
        cmd = ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
               "-s", f"{w}x{h}", "-r", str(fps), "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
               "-c:v", "libx264", "-pix_fmt", "yuv420p", str(mp4)]
        subprocess.run(cmd, input=b"".join(im.tobytes() * r for im, r in zip(images, repeats)), check=True)
        written.append(mp4)
    plt.close(fig)
    return written, [float(d) for d in deltas], durations


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out/teach"))
    args = ap.parse_args()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    scene = make_cue_scene(SCENE)
    bundle = scene.bundle
    a, b = bundle.names
    va, vb = bundle.video(a), bundle.video(b)
    ca, cb = bundle.cameras[a], bundle.cameras[b]
    true_delta = bundle.gt_offsets_s[b] - bundle.gt_offsets_s[a]
    print(f"scene: two static cameras {a} ({va.fps:g} fps) and {b} ({vb.fps:g} fps); "
          f"{b} started {true_delta:+.3f} s after {a}, so the true Δ_ab = {true_delta:+.3f} s")

    # one long-lived matched track to follow through the steps
    pairs = bundle.pair(a, b).index
    xa_all, xb_all = bundle.tracks[a].xy, bundle.tracks[b].xy
    def motion(tr: np.ndarray) -> float:  # extent of a track in the image, px
        ok = np.isfinite(tr[:, 0])
        return float(np.ptp(tr[ok], axis=0).max()) if ok.sum() > 10 else 0.0

    score = [min(np.isfinite(xa_all[i, :, 0]).mean(), np.isfinite(xb_all[j, :, 0]).mean())
             * min(motion(xa_all[i]), motion(xb_all[j])) for i, j in pairs]
    ia, ib = pairs[int(np.argmax(score))]

    def zoom(ax, tr: np.ndarray, v, pad: float = 120.0) -> None:
        ok = np.isfinite(tr[:, 0])
        lo, hi = tr[ok].min(0) - pad, tr[ok].max(0) + pad
        ax.set_xlim(max(0, lo[0]), min(v.width, hi[0]))
        ax.set_ylim(min(v.height, hi[1]), max(0, lo[1]))

    # ---- step 1: epipolar geometry with a moving point ----
    fig, axes = plt.subplots(1, 2, figsize=(14, 6), dpi=100, layout="constrained")
    for ax, v, tr, col in ((axes[0], va, xa_all[ia], A_COLOR), (axes[1], vb, xb_all[ib], B_COLOR)):
        ok = np.isfinite(tr[:, 0])
        sc = ax.scatter(tr[ok, 0], tr[ok, 1], c=v.timestamps_s[ok], cmap="viridis", s=10)
        zoom(ax, tr, v)
        ax.set_aspect("equal")
        ax.set_title(f"{v.name} (zoomed): one moving point, coloured by {v.name}'s own clock", fontsize=11)
        ax.set_xlabel("x [px]")
        ax.set_ylabel("y [px]")
        fig.colorbar(sc, ax=ax, label=f"local time of {v.name} [s]", shrink=0.8)
    fig.suptitle("Step 1. Two cameras see one moving point. Each video has its own clock: "
                 "which of b's frames shows the moment of a's frame?", fontsize=12)
    fig.savefig(out / "step1_geometry.png")
    plt.close(fig)

    # ---- step 2: the cue. b's point at t -> epipolar line in a; a's point at t + Δ on it? ----
    F_ab = fundamental_from_cameras(ca.K, ca.cam_from_world, cb.K, cb.cam_from_world)
    trials = [true_delta - 0.4, true_delta, true_delta + 0.4]

    def wrong_error(t: float) -> float:  # how clearly both wrong offsets miss at b's time t
        xb_t = sample(xb_all[ib:ib + 1], vb.timestamps_s, t)[0]
        errs = [epipolar_residual(F_ab, sample(xa_all[ia:ia + 1], va.timestamps_s, t + d)[0], xb_t)
                for d in (trials[0], trials[2])]
        return float(np.nan_to_num(min(errs), nan=-1.0))

    # one reference moment for every step: a frame of b where the followed point is seen together
    # with most of b's matched points (the sweep draws them) and both wrong offsets clearly miss
    seen = np.isfinite(xb_all[pairs[:, 1], :, 0]).sum(0)
    ok_b = np.flatnonzero(np.isfinite(xb_all[ib, :, 0]) & (seen >= 0.7 * seen.max()))
    k_ref = max(ok_b, key=lambda k: wrong_error(float(vb.timestamps_s[k])))
    t_b = float(vb.timestamps_s[k_ref])
    x_b = xb_all[ib, k_ref]
    line = F_ab @ np.array([x_b[0], x_b[1], 1.0])
    fig, axes = plt.subplots(1, 3, figsize=(18, 4.4), dpi=100, layout="constrained")
    for ax, d in zip(axes, trials):
        x_a = sample(xa_all[ia:ia + 1], va.timestamps_s, t_b + d)[0]
        err = float(epipolar_residual(F_ab, x_a, x_b, "sampson"))
        tr = xa_all[ia]
        ax.plot(tr[:, 0], tr[:, 1], color="#bbbbbb", lw=1.5, label=f"{a}'s track over time")
        ax.axline((0.0, -line[2] / line[1]), slope=-line[0] / line[1], color=B_COLOR, lw=2,
                  label=f"epipolar line of {b}'s point at t = {t_b:.2f} s")
        good = abs(d - true_delta) < 1e-9
        ax.scatter([x_a[0]], [x_a[1]], s=120, color=ACCEPT if good else REJECT, zorder=5,
                   edgecolors="black", label=f"{a}'s point at t + Δ")
        zoom(ax, tr, va)
        ax.set_aspect("equal")
        ax.set_title(f"Δ = {d:+.3f} s{'  (true)' if good else ''}: {px(err)} px from the line",
                     fontsize=11, color=ACCEPT if good else REJECT)
        ax.set_xlabel("x [px]")
        ax.set_ylabel("y [px]")
        ax.legend(loc="best", fontsize=8.5, framealpha=0.9)
    fig.suptitle("Step 2. The cue: x_a(t + Δ)ᵀ F x_b(t) = 0 holds only when Δ is the true offset "
                 "(the point lies on the line)", fontsize=12)
    fig.savefig(out / "step2_cue.png")
    plt.close(fig)

    # ---- step 3: search every Δ: Stage 1 (energy landscape) and Stage 2, recorded to an .rrd ----
    rrd = out / "teach.rrd"
    try:
        from vs_inspect.record.rerun_sink import RerunSink
        sink = RerunSink(rrd, progress=False)
    except ImportError:  # a build without the recording stage
        sink = None
    if sink is not None:
        with sink:
            result = run(bundle, sink=sink, progress=False)
    else:
        result = run(bundle, progress=False)
    land = result.pairs[0]
    fig, ax = plt.subplots(figsize=(10, 4.5), dpi=100, layout="constrained")
    ax.plot(land.offsets_s, land.energy, color="#3b4cc0", lw=1.5, label="E(Δ): robust mean Sampson error")
    ax.axvline(true_delta, color="black", ls="--", label=f"true Δ = {true_delta:+.3f} s")
    ax.axvline(land.best_offset_s, color=ACCEPT, lw=2, alpha=0.7,
               label=f"found Δ = {land.best_offset_s:+.3f} s "
                     f"(error {1000 * abs(land.best_offset_s - true_delta):.1f} ms)")
    ax.set_xlabel(f"Δ = offset({b}) − offset({a}) [s]", fontsize=11)
    ax.set_ylabel("energy", fontsize=11)
    ax.tick_params(labelsize=10)
    ax.set_title("Step 3. Try every Δ, average the error over all matched points and frames, "
                 "take the minimum", fontsize=12)
    ax.legend(loc="upper left", fontsize=10)
    ax.grid(True, alpha=0.3)
    # the minimum up close: ± a few frames, where the true and the found Δ part
    half = 6.0 / min(va.fps or 30.0, vb.fps or 30.0)
    near = np.abs(land.offsets_s - land.best_offset_s) <= half
    # below the curve's plateau, away from its dip: the inset hides none of the landscape
    left = 0.04 if (land.best_offset_s - land.offsets_s.min()) / np.ptp(land.offsets_s) > 0.5 else 0.56
    zoom_ax = ax.inset_axes([left, 0.08, 0.4, 0.62])
    zoom_ax.plot(land.offsets_s[near], land.energy[near], color="#3b4cc0", lw=1.5, marker="o", ms=3)
    zoom_ax.axvline(true_delta, color="black", ls="--")
    zoom_ax.axvline(land.best_offset_s, color=ACCEPT, lw=2, alpha=0.7)
    zoom_ax.set_xlim(land.best_offset_s - half, land.best_offset_s + half)
    zoom_ax.set_title(f"the minimum, ± {half:.2f} s (dots: the candidate offsets)", fontsize=10)
    zoom_ax.tick_params(labelsize=9)
    zoom_ax.grid(True, alpha=0.3)
    ax.indicate_inset_zoom(zoom_ax, edgecolor="0.4")
    fig.savefig(out / "step3_search.png")
    plt.close(fig)

    # ---- step 4: the epipolar plane in 3D, and what b sees ----
    t_a = t_b + true_delta
    x_a_true = sample(xa_all[ia:ia + 1], va.timestamps_s, t_a)[0]
    step4_plane(out / "step4_plane.png", bundle, a, b, ia, ib, t_b, true_delta, x_b, x_a_true, F_ab)

    # ---- step 5: the two-crossings ambiguity ----
    _, k5 = step5_ambiguity(out / "step5_ambiguity.png", bundle, a, b, F_ab, true_delta, land, k_ref)

    # ---- step 6: an animated sweep of Δ ----
    sweep, sweep_deltas, sweep_ms = step6_sweep(out / "step6_sweep.gif", bundle, a, b, F_ab, true_delta,
                                                land, k_ref)
    (out / "steps.json").write_text(json.dumps({
        "reference": {"video": b, "frame": int(k_ref), "time_s": t_b},
        "frames_of_b": {"step2_cue": int(k_ref), "step4_plane": int(k_ref),
                        "step5_ambiguity": k5, "step6_sweep": int(k_ref)},
        "true_delta_s": true_delta, "found_delta_s": float(land.best_offset_s),
        "step3_search": {"zoom_s": [float(land.best_offset_s - half), float(land.best_offset_s + half)]},
        "step6_sweep": {"delta_s": sweep_deltas, "duration_ms": sweep_ms}}, indent=1))

    # ---- the standard report from a run folder ----
    run_dir = out / "run"
    bdir = write_bundle(bundle, run_dir / "bundle", overwrite=True)
    write_run_result(dataclasses.replace(result, inputs=RunInputs(bundle=str(bdir))),
                     run_dir / "result.json")
    render_report(report_data_from_run(run_dir), out / "report")
    print(f"found Δ_ab = {land.best_offset_s:+.4f} s, true {true_delta:+.4f} s, error "
          f"{1000 * abs(land.best_offset_s - true_delta):.1f} ms ({land.decision.reason})")
    print(f"figures: {out}/step1_geometry.png step2_cue.png step3_search.png step4_plane.png "
          f"step5_ambiguity.png {' '.join(p.name for p in sweep)} report/index.html")
    if sink is not None:
        print(f"recording: {rrd}  (rerun {rrd}; scrub offset_ms under pairs/{a}__{b}/epipolar)")
    print(f"done in {time.perf_counter() - t_start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
