"""result.json (DESIGN.md): written atomically, read back with its keys checked."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .atomic import write_json_atomic
from .names import check_video_name
from ..cue_stats import CueStats
from ..result_types import PairDecision, PairLandscape, RateLandscape, RunInputs, RunResult, SolveIteration


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def pair_to_dict(p: PairLandscape, with_landscape: bool = True) -> dict[str, Any]:
    d = p.decision
    out: dict[str, Any] = {
        "a": p.a, "b": p.b,
        "offset_s": _num(p.best_offset_s) if d.accepted or math.isfinite(p.best_offset_s) else None,
        "accepted": bool(d.accepted),
        "reason": d.reason,
        "uncertainty_s": _num(p.uncertainty_s),
        "best_energy": _num(p.best_energy),
        "contrast": d.contrast,
        "second_depth_ratio": d.second_depth_ratio,
        "num_minima": d.num_minima,
        "num_pareto_minima": d.num_pareto_minima,
        "at_range_edge": d.at_range_edge,
        "inlier_fraction": _num(d.inlier_fraction),
        "inlier_tau_px": _num(d.inlier_tau_px),
        "support_fraction": _num(d.support_fraction),
        "track_pairs_at_best": d.track_pairs_at_best,
        "num_track_pairs": p.num_track_pairs,
        "residual": p.residual,
        "robust_scale": _num(p.robust_scale),
        "minima_offsets_s": [float(p.offsets_s[i]) for i in p.minima_idx],
        "minima_energy": [_num(float(p.energy[i])) for i in p.minima_idx],
    }
    if p.pose_free:
        out["pose_free"] = True
    if p.window_s is not None:  # --around: the Δ_ab its videos' windows allow, s
        out["window_s"] = [float(p.window_s[0]), float(p.window_s[1])]
    if p.confirm_energy is not None:  # the pair had unchecked track pairs: the others' own minimum
        out["confirm_offset_s"] = _num(p.confirm_offset_s)
        if with_landscape:
            out["confirm_energy"] = [_num(float(x)) for x in p.confirm_energy]
    if math.isfinite(p.log_rate_std) or p.rate_landscape is not None or p.rate != 1.0:
        # the drift model (v2): τ_a = offset_s + rate · τ_b
        out["rate"] = float(p.rate)
        out["drift_ppm"] = (float(p.rate) - 1.0) * 1e6
        # a standard error needs no 17 digits; rounded, the file reads back and writes again
        # to the same number (the ×1e-6 of reading and the ×1e6 here do not invert exactly)
        std_ppm = _num(p.log_rate_std * 1e6)
        out["drift_std_ppm"] = None if std_ppm is None else round(std_ppm, 6)
        out["pivot_s"] = float(p.pivot_s)
        out["pivot_offset_s"] = _num(p.pivot_offset_s)
        out["pivot_offset_std_s"] = _num(p.pivot_offset_std_s)
        if with_landscape and p.rate_landscape is not None:
            rl = p.rate_landscape
            out["rate_landscape"] = {"pivot_s": float(rl.pivot_s),
                                     "offsets_s": [float(x) for x in rl.offsets_s],
                                     "rates_ppm": [float(x) for x in rl.rates_ppm],
                                     "energy": [[_num(float(x)) for x in row] for row in rl.energy]}
    if with_landscape:
        out["landscape"] = {
            "offsets_s": [float(x) for x in p.offsets_s],
            "energy": [_num(float(x)) for x in p.energy],
            "support": [int(x) for x in p.support],
        }
    return out


def read_json_file(path: str | os.PathLike, name_in_folder: str) -> tuple[Any, Path]:
    """(the JSON content, the file read) of a file, or of name_in_folder in a folder; InputError
    naming the file when it is missing or not JSON."""
    path = Path(path)
    if path.is_dir():
        path = path / name_in_folder
    try:
        return json.loads(path.read_text()), path
    except FileNotFoundError:
        raise InputError(f"{path}: missing file") from None
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None



# ---- RunResult <-> result.json ------------------------------------------------------------------
# Version 2 (the drift model) adds "time_model", and with --drift "drift_ppm" and "drift_std_ppm"
# per video, per pair "rate", "drift_ppm", "drift_std_ppm", "pivot_s", "pivot_offset_s",
# "pivot_offset_std_s", "rate_landscape"; pose-free pairs say "pose_free": true; "gt_drift_ppm"
# when the bundle's gt.json has drift. Every key of version 1 is where it was, so version 1 files
# read as before (constant offsets, no drift).

RESULT_VERSION = 2


def _opt_float(x: Any, what: str) -> float | None:
    if x is None:
        return None
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise InputError(f"{what} must be a number or null, got {type(x).__name__}")
    return float(x)


def run_result_to_dict(r: RunResult) -> dict[str, Any]:
    """result.json's dictionary (DESIGN.md): the keys of format version 1 in the same places, and
    version 2's (above)."""
    out: dict[str, Any] = {
        "format": "vs-inspect-result", "version": RESULT_VERSION,
        "reference": r.reference,
        "time_model": "constant" if r.drift_ppm is None else "drift",
        "offsets_s": {k: _num(v) if v is not None else None for k, v in r.offsets_s.items()},
        "uncertainty_s": {k: _num(v) if v is not None else None for k, v in r.uncertainty_s.items()},
        "unresolved": dict(r.unresolved),
        **({"unresolved_headline": dict(r.unresolved_headline)} if r.unresolved_headline is not None else {}),
        "pairs": [pair_to_dict(p) for p in r.pairs],
        "solve": {
            "solver": r.solver,
            "pairs": [list(p) for p in r.solve_pairs],
            "iterations": [{"residual_s": [float(x) for x in it.residual_s],
                            "weight": [float(w) for w in it.weight]} for it in r.iterations],
        },
        "timings_s": {k: round(v, 4) for k, v in r.timings_s.items()},
    }
    if r.config is not None:
        out["config"] = r.config
    inp = {k: v for k, v in dataclasses.asdict(r.inputs).items() if v not in (None, {})}
    if inp:
        out["input"] = inp
    if r.drift_ppm is not None:
        out["drift_ppm"] = {k: _num(v) if v is not None else None for k, v in r.drift_ppm.items()}
        out["drift_std_ppm"] = {k: _num(v) if v is not None else None
                                for k, v in (r.drift_std_ppm or {}).items()}
    if r.gt_offsets_s is not None:
        out["gt_offsets_s"] = dict(r.gt_offsets_s)
    if r.gt_drift_ppm is not None:
        out["gt_drift_ppm"] = dict(r.gt_drift_ppm)
    if r.cues is not None:
        out["cues"] = r.cues.to_json()
    return out


def _window(w: Any) -> tuple[float, float] | None:
    """A pair's window_s as written (two numbers, or absent)."""
    if w is None:
        return None
    if not (isinstance(w, list) and len(w) == 2):
        raise ValueError(f"pairs[].window_s must be a list of two numbers, got {w!r}")
    return float(w[0]), float(w[1])


def _pair_from_dict(p: dict[str, Any]) -> PairLandscape:
    land = p.get("landscape") or {}
    offsets = np.asarray(land.get("offsets_s", []), dtype=np.float64)
    energy = np.asarray([np.nan if e is None else e for e in land.get("energy", [])], dtype=np.float64)
    support = np.asarray(land.get("support", []), dtype=np.int64)
    minima = [float(m) for m in p.get("minima_offsets_s", [])]
    idx = np.array([int(np.argmin(np.abs(offsets - m))) for m in minima] if offsets.size else [],
                   dtype=np.int64)
    nan = float("nan")

    def f(key: str) -> float:
        v = _opt_float(p.get(key), f"pairs[].{key}")
        return nan if v is None else v

    decision = PairDecision(bool(p["accepted"]), str(p.get("reason", "")), f("contrast"),
                            f("second_depth_ratio"), int(p.get("num_minima", 0)),
                            int(p.get("num_pareto_minima", 0)), bool(p.get("at_range_edge", False)),
                            f("inlier_fraction"), f("inlier_tau_px"), f("support_fraction"),
                            int(p.get("track_pairs_at_best", -1)))
    rate_land = None
    rl = p.get("rate_landscape")
    if isinstance(rl, dict):
        rate_land = RateLandscape(float(rl["pivot_s"]), np.asarray(rl["offsets_s"], dtype=np.float64),
                                  np.asarray(rl["rates_ppm"], dtype=np.float64),
                                  np.asarray([[np.nan if e is None else e for e in row] for row in rl["energy"]],
                                             dtype=np.float64).reshape(len(rl["rates_ppm"]), len(rl["offsets_s"])))
    rate = f("rate")
    return PairLandscape(str(p["a"]), str(p["b"]), offsets, energy, support, idx, f("offset_s"),
                         f("best_energy"), f("uncertainty_s"), int(p.get("num_track_pairs", 0)),
                         decision, str(p.get("residual", "sampson")), f("robust_scale"),
                         1.0 if math.isnan(rate) else rate, f("drift_std_ppm") * 1e-6,
                         float(p.get("pivot_s", 0.0)), f("pivot_offset_s"), f("pivot_offset_std_s"),
                         rate_land, bool(p.get("pose_free", False)), _confirm_energy(p, len(offsets)),
                         f("confirm_offset_s"), _window(p.get("window_s")))


def _confirm_energy(p: dict[str, Any], num_offsets: int) -> np.ndarray | None:
    """A pair's confirm_energy (D,) from its entry: None when the check did not run; without the
    landscape written (with_landscape off) NaN over the offsets."""
    if "confirm_offset_s" not in p:
        return None
    e = p.get("confirm_energy")
    if e is None:
        return np.full(num_offsets, np.nan)
    if not isinstance(e, list) or len(e) != num_offsets:
        raise InputError(f"pairs[].confirm_energy must be a list of {num_offsets} numbers (one per offset)")
    return np.asarray([np.nan if x is None else x for x in e], dtype=np.float64)


def run_result_from_dict(d: dict[str, Any], source: str = "result") -> RunResult:
    """The RunResult of a result.json dictionary; InputError naming the source when malformed."""
    try:
        if not isinstance(d, dict) or not isinstance(d.get("offsets_s"), dict) or "reference" not in d:
            raise InputError("not a vs-inspect result (needs 'reference' and 'offsets_s')")
        offsets = {str(k): _opt_float(v, f"offsets_s[{k!r}]") for k, v in d["offsets_s"].items()}
        for k in offsets:  # names are printed in tables: no forged lines
            problem = check_video_name(k)
            if problem:
                raise InputError(f"video name {k[:40]!r} in offsets_s {problem}")
        unc = {str(k): _opt_float(v, f"uncertainty_s[{k!r}]")
               for k, v in (d.get("uncertainty_s") or {}).items()}
        solve = d.get("solve") or {}
        iters = tuple(SolveIteration(np.asarray(it.get("residual_s", []), dtype=np.float64),
                                     np.asarray(it.get("weight", []), dtype=np.float64))
                      for it in solve.get("iterations", []))
        timings = {str(k): float(v) for k, v in (d.get("timings_s") or {}).items()}
        inp = d.get("input") or {}
        vids = inp.get("videos") or {}
        if isinstance(vids, list):  # older runs listed the videos in bundle order
            vids = {Path(str(v.get("path", v)) if isinstance(v, dict) else str(v)).stem:
                    str(v.get("path")) if isinstance(v, dict) else str(v) for v in vids}
        inputs = RunInputs(inp.get("bundle"), {str(k): str(v) for k, v in vids.items()},
                           inp.get("scene"), inp.get("cues"), _opt_float(inp.get("fps"), "input.fps"))
        cues = None
        if isinstance(d.get("cues"), dict):
            cues = CueStats.from_json(d["cues"], {k.removeprefix("stage0_"): v for k, v in timings.items()
                                                   if k.startswith("stage0_")})
        gt = d.get("gt_offsets_s")
        version = d.get("version", 1)
        if version not in (1, RESULT_VERSION):
            raise InputError(f"result format version {version!r} is not one this reader knows (1, {RESULT_VERSION})")

        def per_video(key: str) -> dict[str, float | None] | None:
            m = d.get(key)
            if m is None:
                return None
            if not isinstance(m, dict):
                raise InputError(f"{key} must be an object {{video: number or null}}")
            return {str(k): _opt_float(v, f"{key}[{k!r}]") for k, v in m.items()}

        drift, drift_std, gt_drift = per_video("drift_ppm"), per_video("drift_std_ppm"), per_video("gt_drift_ppm")
        return RunResult(str(d["reference"]), offsets, unc, {str(k): str(v) for k, v in
                                                             (d.get("unresolved") or {}).items()},
                         tuple(_pair_from_dict(p) for p in d.get("pairs", [])),
                         str(solve.get("solver", "irls")),
                         tuple(tuple(p) for p in solve.get("pairs", [])), iters, timings, inputs,
                         d.get("config"), cues,
                         {str(k): float(v) for k, v in gt.items()} if isinstance(gt, dict) else None,
                         drift, drift_std,
                         {k: v for k, v in gt_drift.items() if v is not None} if gt_drift is not None else None,
                         {str(k): str(v) for k, v in d["unresolved_headline"].items()}
                         if isinstance(d.get("unresolved_headline"), dict) else None)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{source}: malformed result ({type(exc).__name__}: {exc})") from None


def write_run_result(r: RunResult, path: str | os.PathLike) -> Path:
    """result.json written atomically (a folder gets result.json inside)."""
    path = Path(path)
    if path.is_dir():
        path = path / "result.json"
    return write_json_atomic(run_result_to_dict(r), path)


def read_run_result(path: str | os.PathLike) -> RunResult:
    """A result.json (or a run folder holding one) as a RunResult."""
    data, path = read_json_file(path, "result.json")
    return run_result_from_dict(data, str(path))


def write_cue_stats(stats: CueStats, folder: str | os.PathLike, inputs: dict[str, str],
                    total_with_io_s: float | None = None) -> Path:
    """FOLDER/cues_stats.json (atomic): Stage 0's counts, timings and the videos it was given."""
    data = stats.to_json()
    data["timings_s"] = dict(stats.timings_s)
    if total_with_io_s is not None:
        data["timings_s"]["total_with_io_s"] = total_with_io_s
    data["input"] = {"videos": dict(inputs)}
    return write_json_atomic(data, Path(folder) / "cues_stats.json")
