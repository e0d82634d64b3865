"""Loaders: a run folder (result.json + its cue bundle) or a rerun recording (.rrd) alone -> ReportData.

A recording made by RerunSink carries the complete result dictionary as JSON (entity
``meta/result_json``) and the cue bundle it was computed from as a zip archive (entity
``meta/cue_bundle``), so both loaders end in the same prepare.build_report_data.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..io.bundle import read_bundle, read_gt
from ..io.result import read_result
from ..types import CueBundle
from .data import ReportData
from .prepare import build_report_data

log = logging.getLogger(__name__)

RESULT_ENTITY = "meta/result_json"
BUNDLE_ENTITY = "meta/cue_bundle"


def _frame_reader(path: str, index: int) -> np.ndarray | None:
    from ..io.video import open_video, read_frames
    return read_frames(open_video(path), [index])[0]


def _video_paths(result: dict[str, Any], bundle: CueBundle | None, base: Path) -> dict[str, str]:
    """{video name: existing file} from result["input"]["videos"] (a dict, or a list in bundle order)."""
    vids = (result.get("input") or {}).get("videos")
    if not vids:
        return {}
    if isinstance(vids, dict):
        pairs = list(vids.items())
    elif isinstance(vids, list) and bundle is not None and len(vids) == len(bundle.videos):
        pairs = list(zip(bundle.names, vids))
    elif isinstance(vids, list):
        pairs = [(Path(str(v)).stem, v) for v in vids]
    else:
        return {}
    out = {}
    for name, p in pairs:
        if isinstance(p, dict):
            p = p.get("path")
        if not p:
            continue
        for cand in (Path(str(p)), base / str(p)):
            if cand.exists():
                out[str(name)] = str(cand)
                break
    return out


def find_bundle(run_dir: Path, result: dict[str, Any]) -> Path | None:
    """result["input"]["bundle"] (as given, or relative to the run folder), else OUT/cues, OUT/bundle."""
    cands = []
    given = (result.get("input") or {}).get("bundle")
    if given:
        cands += [Path(given), run_dir / given]
    cands += [run_dir / "cues", run_dir / "bundle"]
    for c in cands:
        if (c / "bundle.json").is_file():
            return c
    return None


def load_run(run_dir: str | os.PathLike, pair: tuple[str, str] | None = None) -> ReportData:
    """ReportData of a run folder (OUT/result.json and the cue bundle it names)."""
    run_dir = Path(run_dir)
    result = read_result(run_dir)
    bdir = find_bundle(run_dir, result)
    bundle = read_bundle(bdir) if bdir is not None else None
    if bdir is None:
        log.warning("%s: no cue bundle found (input.bundle, cues/, bundle/)", run_dir)
    gt = result.get("gt_offsets_s")
    if gt is None and bdir is not None and (bdir / "gt.json").is_file():
        gt = read_gt(bdir / "gt.json")
    return build_report_data(result, bundle, source=str(run_dir), gt=gt,
                             video_paths=_video_paths(result, bundle, run_dir), pair=pair,
                             frame_reader=_frame_reader)


# ---- recordings ---------------------------------------------------------------------------


def _last_row(column) -> Any:
    """The last non-null row of a chunk column (a list array)."""
    for i in range(len(column) - 1, -1, -1):
        if column[i].is_valid:
            return column[i]
    return None


def read_rrd_entities(path: Path, wanted: dict[str, str]) -> dict[str, Any]:
    """{key: last logged value} of the given {key: "entity:component"}, read with RrdReader."""
    import rerun.chunk as rc

    try:
        reader = rc.RrdReader(str(path))
        chunks = reader.stream().to_chunks()
    except Exception as exc:  # the reader raises its own types for non-rrd files
        raise InputError(f"{path}: not a readable rerun recording ({exc})") from None
    out: dict[str, Any] = {}
    for ch in chunks:
        ent = str(ch.entity_path).lstrip("/")
        for key, spec in wanted.items():
            e, comp = spec.split(":", 1)
            if ent != e:
                continue
            rb = ch.to_record_batch()
            for name in rb.schema.names:
                if name == comp or name.endswith(":" + comp) or name.split(":")[-1] == comp:
                    row = _last_row(rb.column(name))
                    if row is not None:
                        out[key] = row
    return out


def load_rrd(path: str | os.PathLike, pair: tuple[str, str] | None = None) -> ReportData:
    """ReportData from a recording alone (no run folder, no videos, no recompute)."""
    from ..io.bundle_zip import bundle_from_zip_bytes

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: missing file")
    got = read_rrd_entities(path, {"result": f"{RESULT_ENTITY}:text",
                                   "bundle": f"{BUNDLE_ENTITY}:zip"})
    if "result" not in got:
        raise InputError(f"{path}: the recording has no {RESULT_ENTITY} (was it written by "
                         "vs-inspect's RerunSink after the sync finished?)")
    texts = got["result"].as_py()
    try:
        result = json.loads(texts[-1] if isinstance(texts, list) else texts)
    except (json.JSONDecodeError, TypeError) as exc:
        raise InputError(f"{path}: {RESULT_ENTITY} is not valid JSON ({exc})") from None
    bundle = None
    if "bundle" in got:
        raw = got["bundle"].values.to_numpy(zero_copy_only=False).astype(np.uint8).tobytes()
        bundle = bundle_from_zip_bytes(raw, f"{path}:{BUNDLE_ENTITY}")
    else:
        log.warning("%s: no %s in the recording: 3D scene, timeline and epipolar panel are missing",
                    path, BUNDLE_ENTITY)
    data = build_report_data(result, bundle, source=str(path), gt=result.get("gt_offsets_s"),
                             pair=pair)
    if bundle is None:
        from dataclasses import replace
        data = replace(data, notes=data.notes + (f"the recording has no {BUNDLE_ENTITY}",))
    return data


def load(path: str | os.PathLike, pair: tuple[str, str] | None = None) -> ReportData:
    """A run folder, a result.json, or an .rrd recording."""
    p = Path(path)
    if p.is_dir():
        return load_run(p, pair)
    if p.suffix == ".rrd":
        return load_rrd(p, pair)
    if p.name.endswith(".json") and p.is_file():
        return load_run(p.parent, pair)
    if not p.exists():
        raise InputError(f"{p}: no such run folder or recording")
    raise InputError(f"{p}: give a run folder (with result.json) or a .rrd recording")
