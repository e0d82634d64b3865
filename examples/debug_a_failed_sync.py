"""Debug a failed sync from its recording: three planted failures and how the .rrd and the report
reveal each one.

    python examples/debug_a_failed_sync.py --out out/debug

The scene (vs_inspect.synth.cues) has five cameras; three things are broken on purpose:

  1. a wrong pose: cam1's rotation is off by 8 degrees (a bad calibration or a failed SfM);
  2. all-wrong matches: every cross-view track pair of cam0__cam2 joins two different points;
  3. a camera that never sees the motion: cam4 has no tracks at all.

The script synchronizes the scene while recording to OUT/debug.rrd, then works only from the
recording, as someone who was sent the file would: `vs-inspect inspect` (the decisions and the
suspects it names) and `vs-inspect report` (the figures). It prints, for each planted failure,
where it shows up, and scores inspect's diagnosis against what was planted: true positives,
false positives (an innocent video or pair accused) and misses.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np  # noqa: F401  (before anything that may import pycolmap)

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scipy.spatial.transform import Rotation  # noqa: E402

from vs_inspect.report import figures  # noqa: E402
from vs_inspect.report.figure_style import fmt_px  # noqa: E402
from vs_inspect.report.build import render_report  # noqa: E402
from vs_inspect.analysis.report_data import report_data_from_recording  # noqa: E402
from vs_inspect.pipeline import run  # noqa: E402
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene  # noqa: E402
from vs_inspect.types import CameraTrack, CueBundle, TrackPairs, Tracks  # noqa: E402

SCENE = CueSceneConfig(cameras=5, moving=1, variable_rate=0, seconds=5.0, points_per_object=15,
                       pairs_per_view_pair=150, wrong_fraction=0.2, no_match_pairs=0,
                       all_wrong_pair=False, seed=11)
WRONG_POSE, WRONG_POSE_DEG = "cam1", 8.0
ALL_WRONG = ("cam0", "cam2")
BLIND = "cam4"


def plant_failures(bundle: CueBundle) -> CueBundle:
    rng = np.random.default_rng(0)
    cams = dict(bundle.cameras)
    c = cams[WRONG_POSE]
    R_err = Rotation.from_rotvec(np.deg2rad(WRONG_POSE_DEG) * np.array([0.3, 0.9, 0.3])
                                 / np.linalg.norm([0.3, 0.9, 0.3])).as_matrix()
    T = np.array(c.cam_from_world, copy=True)
    T[..., :3, :3] = R_err @ T[..., :3, :3]
    T[..., :3, 3] = (R_err @ T[..., :3, 3, None])[..., 0]
    cams[WRONG_POSE] = CameraTrack(c.K, T, c.valid)

    pairs = {}
    for key, tp in bundle.pairs.items():
        if BLIND in key:
            continue  # the blind camera has no tracks, so no track pairs either
        if key == ALL_WRONG or key == ALL_WRONG[::-1]:
            idx = tp.index.copy()
            idx[:, 1] = rng.permutation(idx[:, 1])
            tp = TrackPairs(tp.a, tp.b, idx, tp.weight)
        pairs[key] = tp
    tracks = dict(bundle.tracks)
    T_blind = bundle.video(BLIND).num_frames
    tracks[BLIND] = Tracks(np.zeros((0, T_blind, 2), dtype=np.float32))
    return replace(bundle, cameras=cams, pairs=pairs, tracks=tracks)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out/debug"))
    args = ap.parse_args()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    from vs_inspect.record.rerun_sink import RerunSink

    bundle = plant_failures(make_cue_scene(SCENE).bundle)
    rrd = out / "debug.rrd"
    with RerunSink(rrd, progress=False) as sink:
        run(bundle, sink=sink, progress=False)
    print(f"synchronized the broken scene; recording {rrd} ({rrd.stat().st_size / 1e6:.1f} MB)\n")

    # ---- from here on, only the recording is used ----
    from vs_inspect.cli import main as cli
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        cli(["inspect", str(rrd)])
    inspect_text = buf.getvalue()
    print("$ vs-inspect inspect", rrd)
    print(inspect_text)

    data = report_data_from_recording(rrd)
    paths = render_report(data, out / "report")
    # the epipolar panel of a pair with the wrong pose: lines miss at the chosen offset too
    partner = next(p for p in data.pairs if WRONG_POSE in (p.a, p.b) and BLIND not in (p.a, p.b)
                   and set((p.a, p.b)) != set(ALL_WRONG))
    posed = report_data_from_recording(rrd, pair=(partner.a, partner.b))
    wp_png = figures.epipolar(posed, out / "report" / "epipolar_wrong_pose.png")
    allwrong = report_data_from_recording(rrd, pair=ALL_WRONG)
    aw_png = figures.epipolar(allwrong, out / "report" / "epipolar_all_wrong.png") \
        if allwrong.epipolar is not None else None

    print("How each planted failure shows up:\n")
    pv = {p.key: p for p in data.pairs}
    mine = [p for p in data.pairs if WRONG_POSE in (p.a, p.b)]
    print(f"1. wrong pose of {WRONG_POSE} ({WRONG_POSE_DEG:g} degrees):")
    for p in mine:
        err = f", error {p.error_ms:.0f} ms" if p.error_ms is not None else ""
        print(f"   {p.key}: {'accepted' if p.accepted else 'rejected'}{err} — {p.reason}")
    e = posed.epipolar
    if e is not None:
        print(f"   epipolar panel {e.a}–{e.b}: median distance to the lines {fmt_px(e.chosen.median_distance_px)} px "
              f"at the chosen Δ vs {fmt_px(e.wrong.median_distance_px)} px at a wrong one "
              f"(a healthy pair reaches a pixel or two) -> {wp_png}")
    good = data.epipolar
    if good is not None:
        print(f"   for comparison, healthy pair {good.a}–{good.b}: {fmt_px(good.chosen.median_distance_px)} px "
              f"at the chosen Δ")
    print("   in the recording: pairs/<a>__<b>/landscape and .../epipolar of its pairs; "
          "world/cameras shows the frustum turned away")
    key = "__".join(ALL_WRONG)
    p = pv.get(key)
    print(f"\n2. all-wrong matches on {key}:")
    if p is not None:
        print(f"   {key}: {'accepted' if p.accepted else 'rejected'} — {p.reason}")
    if allwrong.epipolar is not None:
        print(f"   its epipolar panel: {fmt_px(allwrong.epipolar.chosen.median_distance_px)} px at "
              f"the 'best' Δ -> {aw_png}")
    print("   in the report: its landscape is framed vermillion (rejected), flat; the graph shows a dashed edge")
    print(f"\n3. {BLIND} never sees the motion:")
    off = data.offsets_s.get(BLIND)
    print(f"   offset: {'unresolved' if off is None else f'{off:+.4f} s'} — "
          f"{data.unresolved.get(BLIND, '')}")
    print("   in the report: the timeline draws it hatched ('unresolved: not placed'), the pair "
          "graph has no accepted edge to it, the landscapes of its pairs are empty")
    print(f"\nreport: {paths['index']}")
    # score inspect's diagnosis against what was planted: every accused video or pair is a true
    # positive when it was planted, else a false positive (a video left unsynchronized only as a
    # consequence of the others is not accused)
    from vs_inspect.analysis.diagnose import diagnose
    from vs_inspect.io.recording import read_recording
    rec = read_recording(rrd)
    diag = diagnose(rec.result, rec.videos)
    planted = {("video", WRONG_POSE): "wrong pose", ("video", BLIND): "blind camera",
               ("pair", key): "all-wrong matches"}
    accused = {(s.kind, s.name): s for s in diag.suspects if s.kind in ("video", "pair")}
    tp = [k for k in accused if k in planted]
    fp = [k for k in accused if k not in planted]
    fn = [k for k in planted if k not in accused]
    print("\ninspect's diagnosis against the planted failures:")
    for k in tp:
        print(f"   true positive  {k[0]} {k[1]} ({planted[k]}): cause {accused[k].cause}")
    for k in fp:
        print(f"   FALSE POSITIVE {k[0]} {k[1]}: {accused[k].message}")
    for k in fn:
        print(f"   missed         {k[0]} {k[1]} ({planted[k]})")
    print(f"   global cause: {diag.global_cause or 'none'}")
    print(f"`vs-inspect inspect` names {len(tp)} of {len(planted)} planted failures; "
          f"false positives: {len(fp)} (innocent videos accused: "
          f"{sorted(n for kind, n in fp if kind == 'video') or 'none'})")
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
