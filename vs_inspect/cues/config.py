"""Settings of Stage 0 (cue extraction from videos), one line per field saying what it does. A
field whose metadata names a "flag" is a command-line option too (pipeline.config generates it);
every field can be set with --set cues.PATH=VALUE. The algorithms' own constants live beside them
in their modules; the measurements behind the defaults are in BENCHMARKS.md."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..errors import check_fields
from .features import FEATURES

CAMERA_FEATURES = tuple(FEATURES) + ("auto",)
PEOPLE_MODES = ("auto", "only", "off")


def _check_numbers(cfg, positive: tuple[str, ...] = (), signed: tuple[str, ...] = ()) -> None:
    """Every number of a Stage 0 config is finite and >= 0 (the counts in `positive` > 0); the
    fields in `signed` may be -1 (their "off" or "all" value)."""
    import dataclasses
    names = tuple(f.name for f in dataclasses.fields(cfg) if f.name not in signed)
    check_fields(cfg, nonnegative=names, positive=positive, at_least={n: -1 for n in signed})


@dataclass(frozen=True)
class GeometricPairConfig:
    enabled: bool = True
    """Add track pairs found by epipolar consistency (static cameras with known geometry)."""
    unchecked_moving: bool = False
    """Without a triangle to check a pair's vote peaks (two cameras, or too many pairs), keep the supporters of every peak of a pair with a moving camera too. Off: it keeps its descriptor pairs only."""
    joint: bool = True
    """With three or more cameras, choose every camera's offset at once from all pairs' vote histograms and keep each pair's supporters of the implied Δ (else: close triangles of top peaks)."""
    joint_min_margin: float = 5.0
    """Joint choice: a camera's pairs are used only if its offset beats the best choice that moves it against every other camera (by over 3 frames) by this much summed vote z-score."""
    three_view_min_supporters: int = 4
    """Estimated cameras, three or more sure: each stays sure only when its tracks follow at least this many trajectories of the other sure cameras at its joint offset; 0 = no check."""
    three_view_min_share_of_best: float = 1.0 / 3.0
    """Three-view check: ...and at least this share of the trajectories followed at the camera's best offset (a right camera at a wrong offset follows few, and many at the right one)."""
    three_view_rival_frames: float = 12.0
    """Three-view check: a peak of a camera's three-view landscape more than this many frames from its joint offset, following more trajectories, is a rival offset; 0 = no such check."""
    three_view_rival_vote_share: float = 0.3
    """A camera with a rival offset is not sure when each pair with another sure camera keeps at least this share of its top vote peak's votes there (the joint offset may be a repeated motion's)."""
    transfer: bool = True
    """Joint choice with two or more sure cameras: an unsure camera's offset is used when its tracks follow the sure cameras' track pairs triangulated and projected into it (point transfer)."""
    transfer_radius_diag: float = 0.006
    """Point transfer: a track follows a projected point when within this fraction of the image diagonal (at least 3 px)."""
    transfer_min_hits: int = 5
    """Point transfer: moments a track must follow a trajectory for it to count."""
    transfer_agree_frames: float = 2.0
    """Point transfer confirms the joint offset when its own peak lies within this many frames of the camera."""
    transfer_min_z: float = 5.0
    """Point transfer: robust z-score its peak needs over the landscape."""
    transfer_min_supporters: int = 8
    """Point transfer: trajectories its peak needs."""
    joint_filter_descriptor: bool = True
    """Joint choice: keep only the descriptor pairs that are epipolar-consistent at the joint Δ (unsure cameras too: at a wrong Δ few survive, and the pair is refused rather than wrong)."""

    def __post_init__(self) -> None:
        _check_numbers(self)


@dataclass(frozen=True)
class CameraConfig:
    features: str = field(default="auto", metadata={"flag": "--sfm-features", "choices": CAMERA_FEATURES})
    """Estimated cameras from SIFT, XFeat or ALIKED features, or auto (SIFT's, then the others while a video is untrusted)."""
    static_frames: int = field(default=9, metadata={
        "flag": "--sfm-frames", "nargs": 2, "type": int, "metavar": ("STATIC", "MOVING"), "default_text": "9 30",
        "help": "estimated cameras: frames per static and per moving camera",
        "apply": lambda v, cam: replace(cam, static_frames=v[0], moving_frames=v[1])})
    """Frames of a static camera whose median (its background) is its one image in the reconstruction."""
    moving_frames: int = 30
    """Frames of a moving camera in the reconstruction (its other frames are registered against it)."""
    max_side: int = 1280
    """Longest side (px) of the reconstruction's images."""
    max_features: int = field(default=3072, metadata={"flag": "--sfm-max-features", "metavar": "N"})
    """Features per reconstruction image at most (COLMAP's mapping time grows with them)."""
    asift_per_view: int = field(default=300, metadata={"flag": "--sfm-asift", "metavar": "N"})
    """ASIFT features per simulated view on a static camera's image (cameras far apart around a floor match); 0: none."""
    auto_aliked_frames: int = field(default=10, metadata={"flag": "--sfm-aliked-frames", "metavar": "N"})
    """Frames per moving camera of ALIKED's model, the last one auto tries; 0: never tried."""
    fallback_from_tracks: bool = True
    """Static cameras from the moving points' two-view geometry may stand in for a camera model's (when no video is trusted on any model, fallback_when_untrusted); off: never fitted."""
    fallback_joint_offsets: bool = True
    """Cameras from the moving points, three or more static cameras: choose their coarse offsets together (all pairs' F inlier shares) instead of each one's best with the reference alone."""
    fallback_when_untrusted: bool = True
    """When the joint vote trusted no video on any model, try the moving points' cameras: used when the model placed fewer than two or they fit the points better, kept when a video is trusted on them."""
    fallback_unchecked_pair: bool = False
    """Use cameras from the moving points when only two come out: geometry and offset are then fitted to the same track pairs, and no third camera checks them. Off: refused, with that reason."""

    def __post_init__(self) -> None:
        if self.features not in CAMERA_FEATURES:
            raise ValueError(f"unknown camera features {self.features!r}: use {', '.join(CAMERA_FEATURES)}")
        _check_numbers(self, positive=("static_frames", "moving_frames", "max_side", "max_features"))


@dataclass(frozen=True)
class CueConfig:
    max_side: int = field(default=640, metadata={"flag": "--max-side"})
    """Longest side (px) frames are downscaled to for moving regions, tracks and matching."""
    max_tracks: int = field(default=1500, metadata={"flag": "--max-tracks"})
    """Tracks alive at once in a video at most."""
    keyframes: int = field(default=12, metadata={"flag": "--keyframes"})
    """Keyframes per video whose SIFT features are matched with every other video's."""
    camera_motion: dict[str, str] = field(default_factory=dict, metadata={
        "flag": "--camera-motion", "append": True, "metavar": "NAME=static|moving",
        "help": "override the automatic static/moving decision for a video (repeatable)",
        "apply": lambda items, cue: replace(cue, camera_motion={**cue.camera_motion, **parse_camera_motion(items)})})
    """Per video, static or moving instead of what its background's motion says."""
    heads: bool = field(default=True, metadata={
        "flag": "--no-heads", "negate": True,
        "help": "do not look for people's heads when a camera moves (MediaPipe BlazePose, when installed: "
                "the worn-camera sightings)"})
    """When a camera moves, time a worn camera by its wearer's head seen in the others (MediaPipe BlazePose)."""
    people: str = field(default="auto", metadata={
        "flag": "--people", "choices": PEOPLE_MODES,
        "help": "people as cross-view correspondences (MediaPipe BlazePose): auto = when the background's cameras "
                "time no video; only = the people's cameras alone; off = never"})
    """Cameras from the people in view (cues/people_cue.py): auto when the background's cameras time no video, only, or off."""
    geometric: GeometricPairConfig = field(default_factory=GeometricPairConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)

    def __post_init__(self) -> None:
        check_fields(self, positive=("max_side", "max_tracks", "keyframes"))
        if self.people not in PEOPLE_MODES:
            raise ValueError(f"unknown people mode {self.people!r}: use {', '.join(PEOPLE_MODES)}")
        bad = {n: m for n, m in self.camera_motion.items() if m not in ("static", "moving")}
        if bad:
            raise ValueError(f"camera_motion must map video names to static or moving, got {bad}")


def parse_camera_motion(items: list[str]) -> dict[str, str]:
    """NAME=static|moving items (--camera-motion) as {name: mode}."""
    out = {}
    for item in items:
        name, _, mode = item.partition("=")
        if mode not in ("static", "moving") or not name:
            raise ValueError(f"--camera-motion must be NAME=static or NAME=moving, got {item!r}")
        out[name] = mode
    return out
