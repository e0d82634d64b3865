"""vs-inspect eval: the paper's metrics of a result against true offsets."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import InputError
from ..eval.metrics import evaluate_offsets, time_errors
from ..io.bundle import read_gt, read_gt_drift
from ..io.result import read_run_result


def register(sub) -> None:
    p = sub.add_parser("eval", help="score a result.json against true offsets",
                       description="Pairwise A@100 and A@500 (%) and per-video δ_mean / δ_med (ms) "
                                   "relative to the result's reference video; per video the offset error in "
                                   "frames (fps from gt.json or the run's bundle) and, when gt.json has "
                                   "drift_ppm, the drift error in ppm.")
    p.add_argument("result", type=Path, help="result.json or the run folder holding it")
    p.add_argument("--gt", type=Path, required=True, help="gt.json with {'offsets_s': {...}} "
                   "(optional 'drift_ppm' and 'fps': {video: number})")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    res = read_run_result(args.result)
    gt = read_gt(args.gt)
    unknown = sorted(set(res.offsets_s) ^ set(gt))
    if unknown:
        raise InputError(f"result and ground truth name different videos: {unknown}")
    if res.reference not in gt:
        raise InputError(f"reference {res.reference!r} has no true offset")
    m = evaluate_offsets(res.offsets_s, gt, res.reference)
    f = lambda x: "nan" if not math.isfinite(x) else f"{x:.1f}"  # noqa: E731
    print(f"{'A@100':>8}{'A@500':>8}{'δ_mean_ms':>11}{'δ_med_ms':>10}{'δ_max_ms':>10}{'unresolved':>12}")
    print(f"{m.a100:>8.1f}{m.a500:>8.1f}{f(m.delta_mean_ms):>11}{f(m.delta_med_ms):>10}"
          f"{f(m.delta_max_ms):>10}{m.num_unresolved:>12}")
    fps = _fps(args.gt, res)
    drift_gt = read_gt_drift(args.gt, list(gt))
    te = time_errors(res.offsets_s, gt, res.reference, fps, res.drift_ppm, drift_gt)
    for v, e in m.per_video_ms.items():
        line = f"  {v:<16}{'unresolved' if e is None else f'{e:.1f} ms'}"
        t = te.get(v)
        if t is not None and t.offset_err_frames is not None:
            line += f"  offset {t.offset_err_frames:+.2f} frames"
        if t is not None and t.drift_err_ppm is not None:
            line += f"  drift {t.drift_err_ppm:+.1f} ppm" + ("" if res.drift_ppm is not None else
                                                             " (constant-offset result: drift taken as 0)")
        print(line)
    return 0


def _fps(gt_path: Path, res) -> dict[str, float] | None:
    """Frame rates for errors in frames: gt.json's "fps", else the result's input bundle's."""
    import json
    for path in (Path(gt_path), Path(res.inputs.bundle or "") / "bundle.json"):
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(data, dict) and isinstance(data.get("fps"), dict):
            return {str(k): float(v) for k, v in data["fps"].items()}
        if isinstance(data, dict) and isinstance(data.get("videos"), list):
            return {str(e["name"]): float(e["fps"]) for e in data["videos"]
                    if isinstance(e, dict) and isinstance(e.get("fps"), (int, float))}
    return None
