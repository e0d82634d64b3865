"""The vs_inspect recording's (.rrd) entity paths and timelines, named once.

RerunSink (record/rerun_sink.py) writes to these paths and the reader (io/recording.py) reads
them back. Video names become entity-path parts through entity_name.
"""

from __future__ import annotations

import re

from ..errors import InputError

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

