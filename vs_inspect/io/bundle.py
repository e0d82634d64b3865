"""Cue bundle v1 (DESIGN.md): reader and writer, validated at the boundary.

Every problem is raised as BundleError naming the file and what is wrong with it.
"""

from __future__ import annotations

import json
import logging
import math
import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import BundleError
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo
from .atomic import atomic_dir, write_json_atomic
from .names import check_video_name

log = logging.getLogger(__name__)

FORMAT = "vs-inspect-cues"
VERSION = 1
POSE_FREE_KEY = "pose_free"  # optional per-video key of bundle.json: the camera has K only
STATIC_POINTS = "static_points.npz"  # optional: the static reconstruction of estimated cameras


MAX_FRAMES = 10_000_000   # 46 h at 60 fps; more is a corrupt or hostile bundle.json
MAX_IMAGE_SIDE_PX = 100_000
MEMORY_BUDGET_ENV = "VS_INSPECT_MEMORY_BUDGET_MB"  # arrays a bundle may hold in memory (default 2048 MB)


def memory_budget_bytes() -> int:
    text = os.environ.get(MEMORY_BUDGET_ENV)
    try:
        mb = float(text) if text else 2048.0
    except ValueError:
        mb = 2048.0
    return int(max(mb, 1.0) * 2**20)


class _Budget:
    """Bytes the bundle's arrays may still take (checked from the .npy headers before loading)."""

    def __init__(self, total: int):
        self.total = total
        self.left = total

    def take(self, path: Path, key: str, nbytes: int) -> None:
        if nbytes > self.left:
            raise BundleError(path, f"array {key!r} would need {nbytes / 2**20:.1f} MB, more than the "
                                    f"memory budget left ({self.left / 2**20:.1f} of {self.total / 2**20:.0f} "
                                    f"MB; set {MEMORY_BUDGET_ENV} to allow more)")
        self.left -= nbytes


def _npy_headers(path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """{array name: (shape, dtype)} of an .npz, read from the .npy headers only (nothing decompressed
    beyond them), so that sizes can be checked before any array is allocated."""
    out = {}
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            if not info.filename.endswith(".npy"):
                continue
            with zf.open(info) as f:
                version = np.lib.format.read_magic(f)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(f)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(f)
                else:
                    raise ValueError(f"unsupported .npy format version {version} in {info.filename}")
            out[info.filename[:-4]] = (tuple(int(n) for n in shape), dtype)
    return out


def _shape_text(shape: tuple) -> str:
    return "(" + ",".join("N" if s is None else str(s) for s in shape) + ")"


# arrays that hold flags (bool allowed); every other array holds numbers, and a bool array there
# is a mistake (a mask saved in place of coordinates), not 0 and 1
FLAG_ARRAYS = frozenset({"valid", "unchecked"})
_NEEDS = {"xy": "float pixel coordinates", "index": "integer track indices", "instance": "integer ids",
          "K": "numbers (a 3x3 camera matrix)", "cam_from_world": "numbers (a 4x4 rigid transform)",
          "weight": "numbers", "chosen_at_offset_s": "a number of seconds"}


def check_numeric_dtype(path, key: str, dtype: np.dtype) -> None:
    """BundleError naming the file and the array unless dtype is a real number type (bool only for
    the flag arrays; never strings, objects, complex numbers or structured records)."""
    dtype = np.dtype(dtype)
    allowed = "biuf" if key in FLAG_ARRAYS else "iuf"
    if dtype.hasobject or dtype.fields is not None or dtype.kind not in allowed:
        kind = {"c": "complex", "b": "bool", "U": "string", "S": "bytes", "O": "object"}.get(dtype.kind, str(dtype))
        need = "bool flags or numbers" if key in FLAG_ARRAYS else _NEEDS.get(key, "numbers")
        raise BundleError(path, f"{key} has dtype {kind}; need {need}")


def _load_npz(path: Path, expect: dict[str, tuple[tuple[int | None, ...], ...]] | None = None,
              budget: _Budget | None = None, note: str = "") -> dict[str, np.ndarray]:
    """The arrays of `expect` (name -> allowed shapes, None = any length) from an .npz, after checking
    every header: real numeric dtype (no objects, no complex), an allowed shape, the memory budget."""
    if not path.is_file():
        raise BundleError(path, "missing file")
    try:
        headers = _npy_headers(path)
    except (ValueError, OSError, zipfile.BadZipFile, EOFError, KeyError) as exc:
        raise BundleError(path, f"not a readable .npz file ({exc})") from None
    wanted = headers if expect is None else {k: v for k, v in headers.items() if k in expect}
    for key, (shape, dtype) in wanted.items():
        check_numeric_dtype(path, key, dtype)
        if expect is not None:
            allowed = expect[key]
            if not any(len(a) == len(shape) and all(w is None or w == s for w, s in zip(a, shape))
                       for a in allowed):
                raise BundleError(path, f"array {key!r} has shape {shape}; expected "
                                        f"{' or '.join(_shape_text(a) for a in allowed)}{note}")
        nbytes = dtype.itemsize
        for n in shape:
            nbytes *= n
        if budget is not None:
            budget.take(path, key, nbytes)
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in wanted}
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
        raise BundleError(path, f"not a readable .npz file ({exc})") from None


def _load_json(path: Path):
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise BundleError(path, "missing file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise BundleError(path, f"not valid JSON ({exc})") from None
    except RecursionError:
        raise BundleError(path, "not usable JSON (nested too deeply)") from None


def _positive_number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0


def _require(path: Path, data: dict, key: str) -> np.ndarray:
    if key not in data:
        raise BundleError(path, f"missing array {key!r} (has {sorted(data)})")
    return data[key]


def _read_video_entry(path: Path, i: int, entry) -> VideoInfo:
    where = f"videos[{i}]"
    if not isinstance(entry, dict):
        raise BundleError(path, f"{where} must be an object, got {type(entry).__name__}")
    name = entry.get("name")
    problem = check_video_name(name)
    if problem:
        shown = repr(name) if not isinstance(name, str) or len(name) <= 40 else repr(name[:40]) + "..."
        raise BundleError(path, f"{where}: 'name' {problem}, got {shown}")
    where = f"video {name!r}"
    limits = {"width": MAX_IMAGE_SIDE_PX, "height": MAX_IMAGE_SIDE_PX, "num_frames": MAX_FRAMES}
    for key, most in limits.items():
        val = entry.get(key)
        if not isinstance(val, int) or isinstance(val, bool) or val < 1:
            raise BundleError(path, f"{where}: {key!r} must be a positive integer, got {val!r}")
        if val > most:
            raise BundleError(path, f"{where}: {key!r} is {val}, more than the {most} allowed")
    fps = entry.get("fps")
    if fps is not None and not _positive_number(fps):
        raise BundleError(path, f"{where}: 'fps' must be a positive finite number, got {fps!r}")
    try:
        ts = entry.get("timestamps_s")
        if ts is not None:
            if not isinstance(ts, list) or not all(isinstance(t, (int, float)) and not isinstance(t, bool)
                                                   for t in ts):
                raise BundleError(path, f"{where}: 'timestamps_s' must be a list of numbers")
            return VideoInfo(name, entry["width"], entry["height"], entry["num_frames"],
                             np.asarray(ts, dtype=np.float64), float(fps) if fps else None)
        if fps is None:
            raise BundleError(path, f"{where}: needs a positive 'fps' or 'timestamps_s', got fps={fps!r}")
        return VideoInfo.constant_rate(name, entry["width"], entry["height"], entry["num_frames"], fps)
    except (ValueError, TypeError) as exc:
        raise BundleError(path, f"{where}: {exc}") from None


def _check_camera(path: Path, cam: CameraTrack) -> None:
    """What the --calib loader checks too: K = [[fx,s,cx],[0,fy,cy],[0,0,1]] with fx, fy > 0, and
    cam_from_world's last row [0,0,0,1]."""
    K = cam.K.reshape(-1, 3, 3)
    if not np.allclose(K[:, 2], [0, 0, 1], atol=1e-9):
        raise BundleError(path, f"the last row of K must be [0, 0, 1], got {K[0, 2].tolist()}")
    if np.any(K[:, 0, 0] <= 0) or np.any(K[:, 1, 1] <= 0):
        raise BundleError(path, "K has a non-positive focal length (K[0,0] and K[1,1] must be > 0)")
    T = cam.cam_from_world.reshape(-1, 4, 4)
    if not np.allclose(T[:, 3], [0, 0, 0, 1], atol=1e-9):
        raise BundleError(path, f"the last row of cam_from_world must be [0, 0, 0, 1], got {T[0, 3].tolist()}")


def _split_pair_name(stem: str, names: list[str]) -> tuple[str, str] | None:
    """'<a>__<b>' -> (a, b), choosing the split where both sides are known videos."""
    parts = stem.split("__")
    for k in range(1, len(parts)):
        a, b = "__".join(parts[:k]), "__".join(parts[k:])
        if a in names and b in names:
            return a, b
    return None


def read_video_infos(folder: str | os.PathLike) -> list[VideoInfo]:
    """The videos of a bundle (names and clocks) from its bundle.json alone, checked as
    read_bundle checks them: no track or camera is loaded."""
    meta_path = Path(folder) / "bundle.json"
    meta = _load_json(meta_path)
    entries = meta.get("videos") if isinstance(meta, dict) else None
    if not isinstance(entries, list) or not entries:
        raise BundleError(meta_path, "empty bundle: 'videos' must be a non-empty list")
    return [_read_video_entry(meta_path, i, e) for i, e in enumerate(entries)]


def read_bundle(folder: str | os.PathLike) -> CueBundle:
    """Read and validate a cue bundle folder."""
    root = Path(folder)
    if not root.is_dir():
        raise BundleError(root, "not a folder (a cue bundle is a folder with bundle.json)")
    meta_path = root / "bundle.json"
    entries, videos, names = _read_meta(meta_path)

    cameras: dict[str, CameraTrack] = {}
    tracks: dict[str, Tracks] = {}
    budget = _Budget(memory_budget_bytes())
    for v in videos:
        cameras[v.name] = _read_camera(root, v, budget)
        tracks[v.name] = _read_tracks(root, v, budget)
    pairs = _read_pairs(root, names, tracks, budget)
    heads = _read_heads(root, videos, names, budget)
    static_points, static_colors = _read_static_points(root, budget)
    gt, gt_drift = None, None
    gt_path = root / "gt.json"
    if gt_path.is_file():
        gt = read_gt(gt_path, names)
        gt_drift = read_gt_drift(gt_path, names)
    # optional per-video key (import-drone): only K is known, the pose is a placeholder
    pose_free = frozenset(str(e["name"]) for e in entries if e.get(POSE_FREE_KEY) is True)
    try:
        return CueBundle(tuple(videos), cameras, tracks, pairs, gt, pose_free, gt_drift, heads,
                         static_points, static_colors)
    except ValueError as exc:
        raise BundleError(root, str(exc)) from None


def _read_meta(meta_path: Path) -> tuple[list, list[VideoInfo], list[str]]:
    """(bundle.json's video entries, each as a VideoInfo, their names), checked: the format and
    version, at least one video, no name twice."""
    if not meta_path.is_file():
        raise BundleError(meta_path, "missing file")
    meta = _load_json(meta_path)
    if not isinstance(meta, dict):
        raise BundleError(meta_path, "must hold a JSON object")
    if meta.get("format") != FORMAT:
        raise BundleError(meta_path, f"'format' must be {FORMAT!r}, got {meta.get('format')!r}")
    if meta.get("version") != VERSION:
        raise BundleError(meta_path, f"'version' must be {VERSION}, got {meta.get('version')!r}")
    entries = meta.get("videos")
    if not isinstance(entries, list) or not entries:
        raise BundleError(meta_path, "empty bundle: 'videos' must be a non-empty list")
    videos = [_read_video_entry(meta_path, i, e) for i, e in enumerate(entries)]
    names = [v.name for v in videos]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise BundleError(meta_path, f"duplicate video names {dupes}")
    return entries, videos, names


def _read_camera(root: Path, v: VideoInfo, budget: _Budget) -> CameraTrack:
    """cameras/<name>.npz of video v, checked against its frames."""
    T = v.num_frames
    cpath = root / "cameras" / f"{v.name}.npz"
    cdata = _load_npz(cpath, {"K": ((3, 3), (T, 3, 3)), "cam_from_world": ((4, 4), (T, 4, 4)),
                              "valid": ((T,),)}, budget,
                      f" (video {v.name!r} has num_frames={T} frames)")
    try:
        cam = CameraTrack(_require(cpath, cdata, "K"), _require(cpath, cdata, "cam_from_world"),
                          cdata.get("valid"))
    except ValueError as exc:
        raise BundleError(cpath, str(exc)) from None
    _check_camera(cpath, cam)
    if cam.is_moving and cam.num_pose_frames != v.num_frames:
        raise BundleError(cpath, f"has {cam.num_pose_frames} per-frame entries but video "
                                 f"{v.name!r} has num_frames={v.num_frames}")
    return cam


def _read_tracks(root: Path, v: VideoInfo, budget: _Budget) -> Tracks:
    """tracks/<name>.npz of video v, checked against its frames."""
    T = v.num_frames
    tpath = root / "tracks" / f"{v.name}.npz"
    tdata = _load_npz(tpath, {"xy": ((None, T, 2),), "instance": ((None,),)}, budget,
                      f" (video {v.name!r} has num_frames={T} frames)")
    try:
        tr = Tracks(_require(tpath, tdata, "xy"), tdata.get("instance"))
    except ValueError as exc:
        raise BundleError(tpath, str(exc)) from None
    if tr.num_frames != v.num_frames:
        raise BundleError(tpath, f"xy has {tr.num_frames} frames (shape {tr.xy.shape}) but "
                                 f"video {v.name!r} has num_frames={v.num_frames}")
    return tr


def _read_pairs(root: Path, names: list[str], tracks: dict[str, Tracks], budget: _Budget
                ) -> dict[tuple[str, str], TrackPairs]:
    """pairs/<a>__<b>.npz (none without the folder), each pair given once, its track indices in
    range of both videos' tracks."""
    pairs: dict[tuple[str, str], TrackPairs] = {}
    pair_dir = root / "pairs"
    if pair_dir.is_dir():
        for ppath in sorted(pair_dir.glob("*.npz")):
            ab = _split_pair_name(ppath.stem, names)
            if ab is None:
                raise BundleError(ppath, f"file name must be <a>__<b>.npz with known videos {names}")
            a, b = ab
            if a == b:
                raise BundleError(ppath, "pairs a video with itself")
            if (b, a) in pairs:
                raise BundleError(ppath, f"pair given twice (also as {b}__{a}.npz)")
            pdata = _load_npz(ppath, {"index": ((None, 2),), "weight": ((None,),), "unchecked": ((None,),),
                                      "chosen_at_offset_s": ((),)}, budget)
            chosen = pdata.get("chosen_at_offset_s")
            try:
                tp = TrackPairs(a, b, _require(ppath, pdata, "index"), pdata.get("weight"), pdata.get("unchecked"),
                                None if chosen is None else float(chosen))
            except ValueError as exc:
                raise BundleError(ppath, str(exc)) from None
            for col, n in ((0, a), (1, b)):
                if len(tp.index) == 0:
                    continue
                bad = (tp.index[:, col] < 0) | (tp.index[:, col] >= tracks[n].num_tracks)
                if bad.any():
                    row = int(np.argmax(bad))
                    raise BundleError(ppath, f"row {row}: track index {int(tp.index[row, col])} out of "
                                             f"range for {n!r} ({tracks[n].num_tracks} tracks)")
            pairs[(a, b)] = tp
        others = [p.name for p in pair_dir.iterdir() if p.suffix != ".npz"]
        if others:
            log.warning("%s: ignoring files that are not .npz: %s", pair_dir, others)
    return pairs


def _read_heads(root: Path, videos: list[VideoInfo], names: list[str], budget: _Budget) -> dict[str, np.ndarray]:
    """heads/<name>.npz: {video: (T,2) px of the head a person detector found}, empty without the
    folder."""
    heads: dict[str, np.ndarray] = {}
    head_dir = root / "heads"  # optional: a person detector's heads (the worn-camera sightings)
    if head_dir.is_dir():
        by_name = {v.name: v for v in videos}
        for hpath in sorted(head_dir.glob("*.npz")):
            if hpath.stem not in by_name:
                raise BundleError(hpath, f"file name must be <video>.npz with a known video {names}")
            T = by_name[hpath.stem].num_frames
            hdata = _load_npz(hpath, {"xy": ((T, 2),)}, budget, f" (video {hpath.stem!r} has num_frames={T} frames)")
            heads[hpath.stem] = _require(hpath, hdata, "xy")
    return heads


def _read_static_points(root: Path, budget: _Budget) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(points (N,3), colours (N,3) uint8) of static_points.npz, (None, None) without it."""
    static_points, static_colors = None, None
    spath = root / STATIC_POINTS  # optional: the static reconstruction of estimated cameras
    if spath.is_file():
        sdata = _load_npz(spath, {"points": ((None, 3),), "colors": ((None, 3),)}, budget)
        static_points = _require(spath, sdata, "points")
        static_colors = sdata.get("colors")
        if static_colors is not None and len(static_colors) != len(static_points):
            raise BundleError(spath, f"{len(static_colors)} colours for {len(static_points)} points")
        if static_colors is not None:
            static_colors = np.clip(static_colors, 0, 255).astype(np.uint8)
    return static_points, static_colors


def read_gt(path: str | os.PathLike, names: list[str] | None = None) -> dict[str, float]:
    """Read {"offsets_s": {...}} and check it names the known videos."""
    path = Path(path)
    if path.is_dir():
        raise BundleError(path, "is a folder; expected a gt.json file")
    data = _load_json(path)
    offs = data.get("offsets_s") if isinstance(data, dict) else None
    if not isinstance(offs, dict) or not offs:
        raise BundleError(path, "needs a non-empty object 'offsets_s'")
    out = {}
    for k, v in offs.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise BundleError(path, f"offset of {k!r} must be a finite number, got {v!r}")
        out[str(k)] = float(v)
    if names is not None:
        unknown = sorted(set(out) - set(names))
        if unknown:
            raise BundleError(path, f"names unknown videos {unknown} (known: {names})")
    return out


def read_gt_drift(path: str | os.PathLike, names: list[str] | None = None) -> dict[str, float] | None:
    """gt.json's optional "drift_ppm" ({video: ppm}, time model t_global = offset_s + (1 + drift)
    * t_local); None when absent."""
    path = Path(path)
    data = _load_json(path)
    d = data.get("drift_ppm") if isinstance(data, dict) else None
    if d is None:
        return None
    if not isinstance(d, dict):
        raise BundleError(path, "'drift_ppm' must be an object {video: ppm}")
    out = {}
    for k, v in d.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise BundleError(path, f"drift_ppm of {k!r} must be a finite number, got {v!r}")
        out[str(k)] = float(v)
    if names is not None and set(out) - set(names):
        raise BundleError(path, f"drift_ppm names unknown videos {sorted(set(out) - set(names))}")
    return out


def write_bundle(bundle: CueBundle, folder: str | os.PathLike, overwrite: bool = False) -> Path:
    """Write a bundle atomically (io.atomic.atomic_dir): a reader never sees half a bundle."""
    dest = Path(folder)
    with atomic_dir(dest, overwrite=overwrite) as tmp:
        videos = []
        for v in bundle.videos:
            entry = {"name": v.name, "width": int(v.width), "height": int(v.height),
                     "num_frames": int(v.num_frames)}
            if v.fps is not None:
                entry["fps"] = float(v.fps)
            const = v.fps is not None and np.allclose(v.timestamps_s, np.arange(v.num_frames) / v.fps,
                                                      atol=1e-9, rtol=0)
            if not const:
                entry["timestamps_s"] = [float(t) for t in v.timestamps_s]
            if v.name in bundle.pose_free:
                entry[POSE_FREE_KEY] = True
            videos.append(entry)
        (tmp / "bundle.json").write_text(
            json.dumps({"format": FORMAT, "version": VERSION, "videos": videos}, indent=1))
        for sub in ("cameras", "tracks", "pairs"):
            (tmp / sub).mkdir()
        for name, cam in bundle.cameras.items():
            arrays = {"K": cam.K, "cam_from_world": cam.cam_from_world}
            if cam.valid is not None:
                arrays["valid"] = cam.valid
            np.savez_compressed(tmp / "cameras" / f"{name}.npz", **arrays)
        for name, tr in bundle.tracks.items():
            arrays = {"xy": tr.xy}
            if tr.instance is not None:
                arrays["instance"] = tr.instance
            np.savez_compressed(tmp / "tracks" / f"{name}.npz", **arrays)
        for (a, b), tp in bundle.pairs.items():
            arrays = {"index": tp.index}
            if tp.weight is not None:
                arrays["weight"] = tp.weight
            if tp.unchecked is not None:
                arrays["unchecked"] = tp.unchecked
            if tp.chosen_at_offset_s is not None:
                arrays["chosen_at_offset_s"] = np.float64(tp.chosen_at_offset_s)
            np.savez_compressed(tmp / "pairs" / f"{a}__{b}.npz", **arrays)
        if bundle.heads:
            (tmp / "heads").mkdir()
            for name, xy in bundle.heads.items():
                np.savez_compressed(tmp / "heads" / f"{name}.npz", xy=xy)
        if bundle.static_points is not None:
            arrays = {"points": np.asarray(bundle.static_points, np.float32)}
            if bundle.static_colors is not None:
                arrays["colors"] = np.asarray(bundle.static_colors, np.uint8)
            np.savez_compressed(tmp / STATIC_POINTS, **arrays)
        if bundle.gt_offsets_s is not None:
            gt: dict = {"offsets_s": bundle.gt_offsets_s}
            if bundle.gt_drift_ppm is not None:
                gt["drift_ppm"] = bundle.gt_drift_ppm
            (tmp / "gt.json").write_text(json.dumps(gt, indent=1))
    return dest
