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
from ..analysis.report_data import build_report_data

log = logging.getLogger(__name__)

RESULT_ENTITY = "meta/result_json"
BUNDLE_ENTITY = "meta/cue_bundle"


def _entity(name: str) -> str:
    try:
        from ..record.rerun_sink import entity_name
        return entity_name(name)
    except ImportError:
        return name


def _frame_reader(path: str, index: int, exact: bool = True) -> np.ndarray | None:
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


def _blob_bytes(row) -> bytes:
    """The bytes of one row of a (possibly nested) list<uint8> column."""
    import pyarrow as pa
    vals = row.values
    while pa.types.is_list(vals.type) or pa.types.is_large_list(vals.type):
        vals = vals.flatten()
    return vals.to_numpy(zero_copy_only=False).astype(np.uint8).tobytes()


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


class RrdFrames:
    """Frames a recording carries: embedded H.264/AV1 assets (exact frames, decoded with PyAV) or
    downscaled JPEG frames (only the frames Stage 0 logged; the nearest one is used)."""

    def __init__(self, assets: dict[str, bytes], jpegs: dict[str, dict[int, bytes]],
                 sizes: dict[str, tuple[int, int]]):
        self.assets, self.jpegs, self.sizes = assets, jpegs, sizes
        self._tmp: dict[str, str] = {}
        self._dir = None

    def names(self) -> list[str]:
        return sorted(set(self.assets) | set(self.jpegs))

    def read(self, name: str, index: int, exact: bool = True) -> np.ndarray | None:
        """(H,W,3) uint8 BGR at full size of frame `index`, or None when the recording lacks it."""
        import cv2
        if name in self.assets:
            from ..io.video import open_video, read_frames
            if name not in self._tmp:
                import tempfile
                if self._dir is None:
                    self._dir = tempfile.TemporaryDirectory(prefix="vs-inspect-rrd-frames-")
                p = Path(self._dir.name) / f"{len(self._tmp)}.mp4"
                p.write_bytes(self.assets[name])
                self._tmp[name] = str(p)
            return read_frames(open_video(self._tmp[name]), [index])[0]
        frames = self.jpegs.get(name) or {}
        if not frames:
            return None
        if index in frames:
            k = index
        elif exact:
            return None
        else:
            keys = np.array(sorted(frames))
            k = int(keys[np.argmin(np.abs(keys - index))])
            gap = np.median(np.diff(keys)) if len(keys) > 1 else 1
            if abs(k - index) > max(1, gap / 2):
                return None
        img = cv2.imdecode(np.frombuffer(frames[k], np.uint8), cv2.IMREAD_COLOR)
        W, H = self.sizes.get(name, (img.shape[1], img.shape[0]))
        if (img.shape[1], img.shape[0]) != (W, H):
            img = cv2.resize(img, (W, H), interpolation=cv2.INTER_LINEAR)
        return img


def read_rrd_frames(path: Path, videos: list[dict[str, Any]]) -> RrdFrames:
    """The frames under videos/<entity>/video (asset) and videos/<entity>/image (JPEG, `frame` timeline)."""
    import rerun.chunk as rc

    by_ent = {f"videos/{v.get('entity', v['name'])}": v for v in videos}
    assets: dict[str, bytes] = {}
    jpegs: dict[str, dict[int, bytes]] = {}
    for ch in rc.RrdReader(str(path)).stream().to_chunks():
        ent = str(ch.entity_path).lstrip("/")
        base, _, leaf = ent.rpartition("/")
        if base not in by_ent or leaf not in ("video", "image"):
            continue
        name = by_ent[base]["name"]
        rb = ch.to_record_batch()
        cols = rb.schema.names
        if leaf == "video":
            col = next((c for c in cols if c.endswith("AssetVideo:blob")), None)
            row = _last_row(rb.column(col)) if col else None
            if row is not None:
                assets[name] = _blob_bytes(row)
        else:
            col = next((c for c in cols if c.endswith("EncodedImage:blob")), None)
            if col is None or "frame" not in cols:
                continue
            fr, blobs = rb.column("frame"), rb.column(col)
            for i in range(len(fr)):
                if fr[i].is_valid and blobs[i].is_valid:
                    jpegs.setdefault(name, {})[int(fr[i].as_py())] = _blob_bytes(blobs[i])
    sizes = {v["name"]: (int(v["width"]), int(v["height"])) for v in videos}
    return RrdFrames(assets, jpegs, sizes)


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
        raw = _blob_bytes(got["bundle"])
        bundle = bundle_from_zip_bytes(raw, f"{path}:{BUNDLE_ENTITY}")
    else:
        log.warning("%s: no %s in the recording: 3D scene, timeline and epipolar panel are missing",
                    path, BUNDLE_ENTITY)
    frames = None
    if bundle is not None:
        try:
            frames = read_rrd_frames(path, [{"name": v.name, "entity": _entity(v.name),
                                             "width": v.width, "height": v.height}
                                            for v in bundle.videos])
        except Exception as exc:  # frames are a backdrop: without them the figures still work
            log.warning("%s: could not read video frames (%s)", path, exc)
    reader = None
    video_paths = None
    if frames is not None and frames.names():
        video_paths = {n: f"rrd:{n}" for n in frames.names()}

        def reader(p: str, index: int, exact: bool = True):
            return frames.read(p[4:], index, exact)
    data = build_report_data(result, bundle, source=str(path), gt=result.get("gt_offsets_s"),
                             pair=pair, video_paths=video_paths, frame_reader=reader)
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
