"""Teach the epipolar synchronization cue on a tiny two-camera scene, step by step.

    python examples/teach_epipolar_cue.py --out out/teach

Writes, into --out:
  step1_geometry.png   two static cameras and one moving point: where it is in each image
  step2_cue.png        b's point at time t gives a line in a; a's point lies on it only at the right Δ
  step3_search.png     the offset search: the energy E(Δ) over all candidate offsets, its minimum
  report/              the standard report (3D scene, landscape, graph, timeline, epipolar panel)
  teach.rrd            the recording: open it with `rerun teach.rrd` and scrub the `offset_ms`
                       timeline under pairs/cam0__cam1/epipolar to watch the lines meet the points

Conventions (DESIGN.md): a frame at local time τ of video v shows global time τ + offset(v), and
Δ_ab = offset(b) − offset(a), so x_a(t + Δ) and x_b(t) show the same moment.
"""

from __future__ import annotations

import argparse
import dataclasses
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

from vs_inspect.geometry.epipolar import epipolar_residual, fundamental_from_cameras  # noqa: E402
from vs_inspect.io.bundle import write_bundle  # noqa: E402
from vs_inspect.io.result import write_run_result  # noqa: E402
from vs_inspect.pipeline import run  # noqa: E402
from vs_inspect.report.build import render_report  # noqa: E402
from vs_inspect.analysis.report_data import report_data_from_run  # noqa: E402
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene  # noqa: E402
from vs_inspect.types import RunInputs  # noqa: E402

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
    for ax, v, tr, col in ((axes[0], va, xa_all[ia], "#1f77b4"), (axes[1], vb, xb_all[ib], "#ff7f0e")):
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

    ok_b = np.flatnonzero(np.isfinite(xb_all[ib, :, 0]))
    t_b = max((float(vb.timestamps_s[k]) for k in ok_b[::3]), key=wrong_error)
    x_b = sample(xb_all[ib:ib + 1], vb.timestamps_s, t_b)[0]
    line = F_ab @ np.array([x_b[0], x_b[1], 1.0])
    fig, axes = plt.subplots(1, 3, figsize=(18, 4.4), dpi=100, layout="constrained")
    for ax, d in zip(axes, trials):
        x_a = sample(xa_all[ia:ia + 1], va.timestamps_s, t_b + d)[0]
        err = float(epipolar_residual(F_ab, x_a, x_b, "sampson"))
        tr = xa_all[ia]
        ax.plot(tr[:, 0], tr[:, 1], color="#bbbbbb", lw=1.5, label=f"{a}'s track over time")
        ax.axline((0.0, -line[2] / line[1]), slope=-line[0] / line[1], color="#ff7f0e", lw=2,
                  label=f"epipolar line of {b}'s point at t = {t_b:.2f} s")
        good = abs(d - true_delta) < 1e-9
        ax.scatter([x_a[0]], [x_a[1]], s=120, color="#1a9850" if good else "#d73027", zorder=5,
                   edgecolors="black", label=f"{a}'s point at t + Δ")
        zoom(ax, tr, va)
        ax.set_aspect("equal")
        ax.set_title(f"Δ = {d:+.3f} s{'  (true)' if good else ''}: Sampson error {err:.3g} px²",
                     fontsize=11, color="#1a9850" if good else "#d73027")
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
    ax.axvline(land.best_offset_s, color="#1a9850", lw=2, alpha=0.7,
               label=f"found Δ = {land.best_offset_s:+.3f} s "
                     f"(error {1000 * abs(land.best_offset_s - true_delta):.1f} ms)")
    ax.set_xlabel(f"Δ = offset({b}) − offset({a}) [s]")
    ax.set_ylabel("energy")
    ax.set_title("Step 3. Try every Δ, average the error over all matched points and frames, "
                 "take the minimum", fontsize=12)
    ax.legend()
    ax.grid(True, alpha=0.3)
    fig.savefig(out / "step3_search.png")
    plt.close(fig)

    # ---- the standard report from a run folder ----
    run_dir = out / "run"
    bdir = write_bundle(bundle, run_dir / "bundle", overwrite=True)
    write_run_result(dataclasses.replace(result, inputs=RunInputs(bundle=str(bdir))),
                     run_dir / "result.json")
    render_report(report_data_from_run(run_dir), out / "report")
    print(f"found Δ_ab = {land.best_offset_s:+.4f} s, true {true_delta:+.4f} s, error "
          f"{1000 * abs(land.best_offset_s - true_delta):.1f} ms ({land.decision.reason})")
    print(f"figures: {out}/step1_geometry.png step2_cue.png step3_search.png report/index.html")
    if sink is not None:
        print(f"recording: {rrd}  (rerun {rrd}; scrub offset_ms under pairs/{a}__{b}/epipolar)")
    print(f"done in {time.perf_counter() - t_start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
