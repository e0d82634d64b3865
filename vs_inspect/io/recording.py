"""The vs_inspect recording (.rrd): its entity paths, named once, and the one reader of it.

RerunSink (record/rerun_sink.py) writes to these paths; `inspect`, the report and the examples
read them back here, without recomputing anything: the run's result (result.json, at
META_RESULT, turned into a RunResult), the recording's own metadata, the structured entities
(landscape series, decisions, solve iterations), the embedded cue bundle and the video frames.
Uses rerun.chunk.RrdReader (rerun-sdk 0.41).
"""

from __future__ import annotations

import json
import re
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..types import CueBundle, RunResult, frame_length_s
from .result import run_result_from_dict

RECORDING_FORMAT = "vs-inspect-recording"
RECORDING_VERSION = 1
APPLICATION_ID = "vs_inspect"

# ---- entity paths -----------------------------------------------------------------------------

META_RESULT = "meta/result_json"  # result.json's dictionary as JSON text
META_RECORDING = "meta/recording_json"  # format, versions, options, pairs logged
META_CONFIG = "meta/config_json"  # the run's config as JSON text
META_VIDEOS = "meta/videos_json"  # the videos (name, entity, size, frames, rate) and the truth
META_BUNDLE = "meta/cue_bundle"  # the cue bundle folder as a zip (component `zip`, uint8)

VIDEOS = "videos"
WORLD = "world"
WORLD_POINTS = "world/points"  # static 3D points of the reconstruction
PAIRS = "pairs"
SYNC_GRAPH = "sync/graph"
SYNC_OFFSETS = "sync/offsets"
SYNC_SOLVE = "sync/solve"
SYNC_IRLS = "sync/irls"  # the robust solve's residual and weight per pair and iteration as bar charts (any timeline)
SYNC_PAIRS = "sync/pairs"  # every pair's verdict, Δ and reason as one table (failed pairs first)
SYNC_LOOPS = "sync/loops"  # loop-closure residual Δ_ab + Δ_bc − Δ_ac per triangle of pairs
CUES_TRANSFER = "cues/transfer"  # Stage 0's point-transfer checks of cameras the joint vote was unsure of
CUES_THREE_VIEW = "cues/three_view"  # Stage 0's three-view checks of cameras the joint vote was sure of
GUIDE = "guide"  # "how to read this recording" (markdown)
LOG = "log"
LOG_DECISIONS = "log/decisions"

# timelines
TIMELINE_FRAME = "frame"  # a video's frame index
TIMELINE_TIME = "time"  # global time after sync, seconds
TIMELINE_OFFSET_MS = "offset_ms"  # a pair's candidate Δ_ab, whole milliseconds
TIMELINE_ITERATION = "iteration"  # Stage 2's IRLS iteration
TIMELINE_EVENT = "event"  # order of log messages
TIMELINE_KEYFRAME_PAIR = "keyframe_pair"  # Stage 0's keyframe pairs of a video pair, row-major (keyframe of a, of b)


def entity_name(name: str) -> str:
    """A video name as one entity-path part (letters, digits, - and _ kept; others become _)."""
    return re.sub(r"[^A-Za-z0-9_\-]", "_", name) or "_"


def check_entity_names(names, known: dict[str, str] | None = None) -> dict[str, str]:
    """{entity: video name} of `names` (added to `known`); InputError naming both videos when two
    names map to one entity (cam.1 and cam_1 would merge their data in the recording)."""
    seen = dict(known or {})
    for n in names:
        e = entity_name(n)
        if seen.get(e, n) != n:
            raise InputError(f"videos {seen[e]!r} and {n!r} would share the recording entity {e!r} "
                             "(names differ only in characters an entity path cannot hold); "
                             "rename one of them, or write no recording (--no-rrd)")
        seen[e] = n
    return seen


def pair_key(a: str, b: str) -> str:
    """The entity-path part of the ordered pair (a, b): "<a>__<b>"."""
    return f"{entity_name(a)}__{entity_name(b)}"


def pair_path(a: str, b: str) -> str:
    return f"{PAIRS}/{pair_key(a, b)}"


def pair_landscape_path(a: str, b: str) -> str:
    """Series energy, minima, chosen and truth on the offset_ms timeline."""
    return f"{pair_path(a, b)}/landscape"


def pair_rate_landscape_path(a: str, b: str) -> str:
    """The drift model's (Δ, rate) energy: "image" (rr.Image, RGB: columns the offset at the
    pivot, rows the rate) and "energy" (rr.Tensor, rows rate_ppm, columns offset)."""
    return f"{pair_path(a, b)}/rate_landscape"


def pair_decision_path(a: str, b: str) -> str:
    return f"{pair_path(a, b)}/decision"


def pair_epipolar_path(a: str, b: str) -> str:
    return f"{pair_path(a, b)}/epipolar"


def pair_matches_path(a: str, b: str) -> str:
    """Stage 0's descriptor matches per keyframe pair: a count series on the keyframe_pair
    timeline, and /grid the (keyframes of a, keyframes of b) counts as a tensor."""
    return f"{pair_path(a, b)}/keyframe_matches"


def transfer_path(name: str) -> str:
    """A camera's point-transfer check: series share (of the projected samples that land on
    their track) over its candidate offset_s on the offset_ms timeline, and points joint (the
    joint vote's offset) and peak (the transfer's own)."""
    return f"{CUES_TRANSFER}/{entity_name(name)}"


def three_view_path(name: str) -> str:
    """A sure camera's three-view check: series supporters (trajectories of the other sure
    cameras followed by one of its tracks) over its candidate offset_s on the offset_ms
    timeline, and a point joint at the joint vote's offset."""
    return f"{CUES_THREE_VIEW}/{entity_name(name)}"


def pair_votes_path(a: str, b: str) -> str:
    """Stage 0's epipolar-consistency votes of the pair over Δ_ab on the offset_ms timeline (the
    landscape's axis): series z (robust z-scores, what the joint vote sums), count (raw votes)
    and a point chosen (the Δ Stage 0 kept the supporters of, when it kept any)."""
    return f"{pair_path(a, b)}/votes"


def video_path(name: str) -> str:
    return f"{VIDEOS}/{entity_name(name)}"


def video_asset_path(name: str) -> str:
    """The embedded H.264/AV1 file (rr.AssetVideo) and its frame references."""
    return f"{video_path(name)}/video"


def video_image_path(name: str) -> str:
    """JPEG frames on the frame timeline."""
    return f"{video_path(name)}/image"


def video_mask_path(name: str) -> str:
    return f"{video_path(name)}/mask"


def video_tracks_path(name: str) -> str:
    return f"{video_path(name)}/tracks"


def video_still_path(name: str) -> str:
    """One static frame (with its mask and tracks below it), so that the video's view shows
    something on timelines where the video has no time (offset_ms)."""
    return f"{video_path(name)}/still"


def camera_path(name: str) -> str:
    return f"{WORLD}/cameras/{entity_name(name)}"


def camera_labels_path() -> str:
    """Each camera's centre as a labelled point (the frustums themselves carry no text)."""
    return f"{WORLD}/camera_labels"


def camera_trail_path(name: str) -> str:
    """A moving camera's centres as a line."""
    return f"{WORLD}/camera_paths/{entity_name(name)}"


def trajectory_path(a: str, b: str) -> str:
    return f"{WORLD}/trajectories/{pair_key(a, b)}"


def solve_residual_path(a: str, b: str) -> str:
    return f"{SYNC_SOLVE}/residual_ms/{pair_key(a, b)}"


def solve_weight_path(a: str, b: str) -> str:
    return f"{SYNC_SOLVE}/weight/{pair_key(a, b)}"


def irls_residual_path(a: str, b: str) -> str:
    return f"{SYNC_IRLS}/residual_ms/{pair_key(a, b)}"


def irls_weight_path(a: str, b: str) -> str:
    return f"{SYNC_IRLS}/weight/{pair_key(a, b)}"


def log_path(stage: str) -> str:
    return f"{LOG}/{entity_name(stage)}"


# ---- what the reader returns ------------------------------------------------------------------


@dataclass(frozen=True)
class LandscapeSeries:
    """One series of a pair's landscape as logged (offset in whole milliseconds)."""

    offset_ms: np.ndarray  # (D,) int, the `offset_ms` timeline values
    value: np.ndarray  # (D,) float


@dataclass(frozen=True)
class RecordedVideo:
    """One video as META_VIDEOS describes it (no timestamps: the cue bundle has those)."""

    name: str
    entity: str  # its entity-path part (entity_name)
    width: int  # px
    height: int  # px
    num_frames: int
    fps: float | None  # None for variable frame rate
    duration_s: float  # local time of the last frame minus the first, seconds

    @property
    def frame_length_s(self) -> float:
        """types.frame_length_s: 1/fps, else the mean spacing of frames (inf for a single frame)."""
        return frame_length_s(self.fps, self.duration_s, self.num_frames)

    @property
    def frame_interval_s(self) -> float:
        """frame_length_s (a recording has no timestamps to take a median of)."""
        return self.frame_length_s


@dataclass
class Recording:
    path: Path
    meta: dict[str, Any]  # META_RECORDING: format, versions, options, pairs logged
    result: RunResult | None  # META_RESULT (None: the run stopped before Stage 2)
    config: dict[str, Any] | None  # META_CONFIG
    videos: tuple[RecordedVideo, ...] = ()  # META_VIDEOS
    gt_offsets_s: dict[str, float] | None = None  # the truth logged with the videos, when known
    decisions: dict[str, str] = field(default_factory=dict)  # pair_key -> markdown
    landscapes: dict[str, dict[str, LandscapeSeries]] = field(default_factory=dict)  # pair_key -> series
    solve: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # residual_ms/weight -> pair_key -> (I,)
    bundle_zip: bytes | None = None  # META_BUNDLE (only when read with bundle=True)
    entities: list[str] = field(default_factory=list)


# ---- reading ----------------------------------------------------------------------------------


def _column(rb, name: str) -> list:
    if name not in rb.schema.names:
        return []
    return rb.column(name).to_pylist()


def _first_text(rb) -> str | None:
    for v in _column(rb, "TextDocument:text"):
        if isinstance(v, list):
            v = v[0] if v else None
        if v is not None:
            return str(v)
    return None


def _scalars(rb, timeline: str) -> tuple[np.ndarray, np.ndarray]:
    t = _column(rb, timeline)
    s = _column(rb, "Scalars:scalars")
    vals = [(x[0] if isinstance(x, list) and x else x) for x in s]
    keep = [i for i, v in enumerate(vals) if v is not None and t and t[i] is not None]
    return np.array([t[i] for i in keep], dtype=np.int64), np.array([vals[i] for i in keep], dtype=float)


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


def _reader(path: Path):
    """(RrdReader, the vs_inspect store); InputError for a missing, corrupt or empty file."""
    if not path.is_file():
        raise InputError(f"{path}: no such recording file")
    try:
        import rerun.chunk as rrc
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = rrc.RrdReader(str(path))
            stores = reader.recordings()
    except Exception as exc:  # noqa: BLE001 - rerun raises RuntimeError/ValueError with a message
        raise InputError(f"{path}: not a readable .rrd recording ({exc})") from None
    if not stores:
        raise InputError(f"{path}: the .rrd holds no recording")
    store = next((s for s in stores if s.application_id == APPLICATION_ID), stores[0])
    return reader, store


def _chunks(path: Path, content: list[str]) -> list:
    reader, store = _reader(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return reader.stream(store=store).filter(content=content).to_chunks()
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{path}: the .rrd is damaged or incomplete ({exc})") from None


def read_recording(path: str | Path, with_structure: bool = True, bundle: bool = False) -> Recording:
    """Read a recording; InputError for a missing, corrupt or non-vs_inspect file.

    with_structure: also the landscapes, decisions and solve iterations (else metadata only).
    bundle: also the embedded cue bundle's zip bytes (Recording.bundle_zip).
    """
    path = Path(path)
    _, store = _reader(path)
    content = [f"/{p}/**" for p in (("meta", PAIRS, SYNC_SOLVE) if with_structure else ("meta",))]
    texts: dict[str, str] = {}
    rec = Recording(path, {}, None, None)
    entities = set()
    for ch in _chunks(path, content):
        ent = ch.entity_path.lstrip("/")
        entities.add(ent)
        rb = ch.to_record_batch()
        if ent == META_BUNDLE:
            col = next((c for c in rb.schema.names if c.split(":")[-1] == "zip"), None)
            row = _last_row(rb.column(col)) if col and bundle else None
            if row is not None:
                rec.bundle_zip = _blob_bytes(row)
            continue
        if ent.startswith("meta/") or ent.endswith("/decision"):
            txt = _first_text(rb)
            if txt is not None:
                texts[ent] = txt
            continue
        parts = ent.split("/")
        if len(parts) == 4 and parts[0] == PAIRS and parts[2] == "landscape":
            t, v = _scalars(rb, TIMELINE_OFFSET_MS)
            if len(t):
                old = rec.landscapes.setdefault(parts[1], {}).get(parts[3])
                if old is not None:
                    t, v = np.concatenate([old.offset_ms, t]), np.concatenate([old.value, v])
                order = np.argsort(t, kind="stable")
                rec.landscapes[parts[1]][parts[3]] = LandscapeSeries(t[order], v[order])
        elif len(parts) == 4 and f"{parts[0]}/{parts[1]}" == SYNC_SOLVE:
            t, v = _scalars(rb, TIMELINE_ITERATION)
            if len(t):
                rec.solve.setdefault(parts[2], {})[parts[3]] = v[np.argsort(t)]
    rec.entities = sorted(entities)
    if META_RECORDING not in texts:
        raise InputError(f"{path}: not a vs_inspect recording (no {META_RECORDING}; application "
                         f"{store.application_id!r})")
    try:
        rec.meta = json.loads(texts[META_RECORDING])
        result = json.loads(texts[META_RESULT]) if META_RESULT in texts else None
        rec.config = json.loads(texts[META_CONFIG]) if META_CONFIG in texts else None
        videos = json.loads(texts[META_VIDEOS]) if META_VIDEOS in texts else {}
    except (json.JSONDecodeError, RecursionError) as exc:
        raise InputError(f"{path}: damaged vs_inspect metadata ({type(exc).__name__}: {exc})") from None
    if not isinstance(rec.meta, dict) or rec.meta.get("format") != RECORDING_FORMAT:
        shown = rec.meta.get("format") if isinstance(rec.meta, dict) else type(rec.meta).__name__
        raise InputError(f"{path}: not a vs_inspect recording ({META_RECORDING}: format {shown!r})")
    if rec.config is not None and not isinstance(rec.config, dict):
        raise InputError(f"{path}: {META_CONFIG} must be a JSON object, got {type(rec.config).__name__}")
    if result is not None:
        rec.result = run_result_from_dict(result, f"{path}:{META_RESULT}")
    try:
        if not isinstance(videos, dict) or not isinstance(videos.get("videos", []), list):
            raise TypeError(f"must be an object with a list 'videos', got {type(videos).__name__}")
        rec.videos = tuple(RecordedVideo(str(v["name"]), str(v.get("entity", entity_name(v["name"]))),
                                         int(v["width"]), int(v["height"]), int(v["num_frames"]),
                                         None if v.get("fps") is None else float(v["fps"]),
                                         float(v.get("duration_s") or 0.0))
                           for v in videos.get("videos", []))
        gt = videos.get("gt_offsets_s")
        rec.gt_offsets_s = {str(k): float(v) for k, v in gt.items()} if isinstance(gt, dict) else None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{path}: damaged {META_VIDEOS} ({type(exc).__name__}: {exc})") from None
    rec.decisions = {k.split("/")[1]: v for k, v in texts.items() if k.startswith(f"{PAIRS}/")}
    return rec


def read_recorded_bundle(rec: Recording) -> CueBundle | None:
    """The cue bundle embedded at META_BUNDLE (read_recording(..., bundle=True)); None if absent."""
    if rec.bundle_zip is None:
        return None
    from .bundle_zip import bundle_from_zip_bytes
    return bundle_from_zip_bytes(rec.bundle_zip, f"{rec.path}:{META_BUNDLE}")


def _entity_rows(path: Path, entity: str) -> list:
    """Record batches of one entity (InputError if the file cannot be read)."""
    return [c.to_record_batch() for c in _chunks(path, [f"/{entity}"])
            if c.entity_path.lstrip("/") == entity]


def read_video_frames(path: str | Path, video: str) -> dict[int, np.ndarray]:
    """{frame index: BGR image} of the JPEG frames logged at video_image_path(video).

    Images are as logged (downscaled by default): multiply pixel coordinates by
    video width / image width to get full-resolution pixels. Empty when the video was logged as an
    embedded video asset or without frames.
    """
    import cv2

    out: dict[int, np.ndarray] = {}
    for rb in _entity_rows(Path(path), video_image_path(video)):
        frames, blobs = _column(rb, TIMELINE_FRAME), _column(rb, "EncodedImage:blob")
        for k, blob in zip(frames, blobs):
            if k is None or not blob:
                continue
            data = np.asarray(blob[0] if isinstance(blob[0], list) else blob, dtype=np.uint8)
            img = cv2.imdecode(data, cv2.IMREAD_COLOR)
            if img is not None:
                out[int(k)] = img
    return out


def read_rate_landscape(path: str | Path, a: str, b: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(the (H,W,3) uint8 RGB image, the (V,U) float32 energy) logged at pair_rate_landscape_path
    (the drift model's (Δ, rate) landscape of pair (a, b)); None for what is not there."""
    base = pair_rate_landscape_path(a, b)
    image = energy = None
    for rb in _entity_rows(Path(path), f"{base}/image"):
        buf, fmt = _column(rb, "Image:buffer"), _column(rb, "Image:format")
        if buf and buf[-1] and fmt and fmt[-1]:
            f = fmt[-1][0] if isinstance(fmt[-1], list) else fmt[-1]
            data = np.asarray(buf[-1][0] if isinstance(buf[-1][0], list) else buf[-1], dtype=np.uint8)
            image = data.reshape(int(f["height"]), int(f["width"]), -1)
    for rb in _entity_rows(Path(path), f"{base}/energy"):
        col = _column(rb, "Tensor:data")
        if col and col[-1]:
            t = col[-1][0] if isinstance(col[-1], list) else col[-1]
            shape = [int(s) for s in t["shape"]]
            energy = np.asarray(t["buffer"], dtype=np.float32).reshape(shape)
    return image, energy


@dataclass(frozen=True)
class EpipolarSweepSeries:
    """What a pair's epipolar view shows over the offsets it was logged at."""

    offset_ms: np.ndarray  # (D,) int, candidate Δ_ab on the offset_ms timeline
    lines: np.ndarray  # (D,) int, epipolar line segments drawn over a's image at each offset
    median_px: np.ndarray  # (D,) median distance of a's points from their lines, px (NaN: none)


def read_epipolar_sweep(path: str | Path, a: str, b: str) -> EpipolarSweepSeries | None:
    """The line counts and median point-line distances of pair (a, b)'s epipolar view (None:
    the pair has no epipolar view)."""
    base = pair_epipolar_path(a, b)
    counts: dict[int, int] = {}
    for rb in _entity_rows(Path(path), f"{base}/lines"):
        t = _column(rb, TIMELINE_OFFSET_MS)
        for ms, strips in zip(t, _column(rb, "LineStrips2D:strips")):
            if ms is not None and strips is not None:
                counts[int(ms)] = len(strips)
    if not counts:
        return None
    med: dict[int, float] = {}
    for rb in _entity_rows(Path(path), f"{base}/median_distance_px"):
        t, v = _scalars(rb, TIMELINE_OFFSET_MS)
        med.update(zip(t.tolist(), v.tolist()))
    ms = np.array(sorted(counts), dtype=np.int64)
    return EpipolarSweepSeries(ms, np.array([counts[m] for m in ms], dtype=np.int64),
                               np.array([med.get(int(m), np.nan) for m in ms], dtype=float))


def read_chunks(path: str | Path, entities: list[str]) -> list:
    """The chunks of the given entities (exact paths), as rerun.chunk.Chunk (InputError if the
    file cannot be read); for copying a recording's parts into another."""
    wanted = {e.strip("/") for e in entities}
    return [c for c in _chunks(Path(path), [f"/{e}" for e in sorted(wanted)])
            if c.entity_path.strip("/") in wanted]


def read_static_points(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(N,3) static 3D points of the reconstruction at WORLD_POINTS and their (N,3) uint8 colours."""
    pts, cols = np.zeros((0, 3)), None
    for rb in _entity_rows(Path(path), WORLD_POINTS):
        p = _column(rb, "Points3D:positions")
        if p and p[-1]:
            pts = np.asarray(p[-1], dtype=float)
        c = _column(rb, "Points3D:colors")
        if c and c[-1]:
            rgba = np.asarray(c[-1], dtype=np.uint32)
            cols = np.stack([(rgba >> 24) & 255, (rgba >> 16) & 255, (rgba >> 8) & 255], -1).astype(np.uint8)
    return pts, cols


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
            from .video import open_video, read_frames
            if name not in self._tmp:
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


def read_rrd_frames(path: str | Path, videos: list[tuple[str, int, int]]) -> RrdFrames:
    """The frames at video_asset_path (asset) and video_image_path (JPEG, `frame` timeline) of
    the given videos, as (name, width px, height px)."""
    by_ent = {video_path(name): name for name, _, _ in videos}
    assets: dict[str, bytes] = {}
    jpegs: dict[str, dict[int, bytes]] = {}
    for ch in _chunks(Path(path), [f"/{VIDEOS}/**"]):
        ent = str(ch.entity_path).lstrip("/")
        base, _, leaf = ent.rpartition("/")
        if base not in by_ent or leaf not in ("video", "image"):
            continue
        name = by_ent[base]
        rb = ch.to_record_batch()
        cols = rb.schema.names
        if leaf == "video":
            col = next((c for c in cols if c.endswith("AssetVideo:blob")), None)
            row = _last_row(rb.column(col)) if col else None
            if row is not None:
                assets[name] = _blob_bytes(row)
        else:
            col = next((c for c in cols if c.endswith("EncodedImage:blob")), None)
            if col is None or TIMELINE_FRAME not in cols:
                continue
            fr, blobs = rb.column(TIMELINE_FRAME), rb.column(col)
            for i in range(len(fr)):
                if fr[i].is_valid and blobs[i].is_valid:
                    jpegs.setdefault(name, {})[int(fr[i].as_py())] = _blob_bytes(blobs[i])
    sizes = {name: (int(w), int(h)) for name, w, h in videos}
    return RrdFrames(assets, jpegs, sizes)
