"""COLMAP's database for one reconstruction: the SfM images written with their masks, features
(COLMAP's SIFT, with ASIFT on the static cameras' images, or learned ones) and their matches over the
image pairs chosen, verified and matched again along their two-view geometry. Every run of one
input gives one database (fixed seeds, one matching thread)."""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import tempfile
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np  # noqa: I001  (numpy before pycolmap, see ENVIRONMENT.md)

from ... import signals
from ...signals import import_pycolmap
from ..config import CameraConfig
from ..features.guided import guided_matches

log = logging.getLogger(__name__)

# threads of SIFT extraction; -1 = all cores. Matching and the mapper stay on one: with two
# matching threads, 2 of 10 runs on one database gave other matches (a pair 235 instead of 1058,
# so another camera model), with one 12 of 12 were identical at about the same wall time; with
# several mapper threads other cameras registered from run to run
SFM_THREADS = -1
SFM_MATCH_THREADS = 1
# a moving camera's images matched with its own up to this many places away and a power of two
# away (COLMAP's sequential matching), and with every other video's; 0: every pair
SEQUENCE_OVERLAP = 5


def sfm_image_file(frame_index) -> str:
    """The file an SfM frame is written to in its video's folder; zero-padded, so name order is frame order."""
    return f"{int(frame_index):06d}.jpg"


def sfm_image_pairs(names: list[str], moving: dict[str, bool], overlap: int) -> list[tuple[str, str]]:
    """The SfM image pairs to match, names "video/frame.jpg" in the given order.

    Images of different videos: every pair. Two frames of one moving video, i < j in its sorted
    SfM frames: when j - i <= overlap or j - i is a power of two (COLMAP's sequential matching
    with quadratic overlap); overlap 0: every pair.
    """
    video = {n: n.split("/")[0] for n in names}
    seen: dict[str, int] = {}
    rank: dict[str, int] = {}  # place of each frame in its video's sorted frames
    for n in sorted(names):
        rank[n] = seen[video[n]] = seen.get(video[n], -1) + 1
    out = []
    for ia, a in enumerate(names):
        sequential = overlap > 0 and moving.get(video[a], False)
        for b in names[ia + 1:]:
            gap = abs(rank[a] - rank[b])
            if sequential and video[b] == video[a] and gap > overlap and gap & (gap - 1):
                continue  # neither a neighbour nor a power of two apart
            out.append((a, b))
    return out


def seeded_verification(seed: int):
    """COLMAP's two-view geometric verification with a seeded RANSAC.

    Its RANSAC runs in worker threads that set_random_seed does not reach: unseeded, repeated runs
    on one input registered different numbers of cameras."""
    pycolmap = import_pycolmap()

    verify = pycolmap.TwoViewGeometryOptions()
    verify.ransac.random_seed = seed
    return verify


def sift_database(db: Path, img_dir: Path, reader, cfg: CameraConfig, few: bool, seed: int,
                   moving: dict[str, bool] | None = None,
                   after_extraction: Callable[[], None] | None = None) -> None:
    """COLMAP's SIFT features and matching (the pairs of sfm_image_pairs: exhaustive when that is
    every pair) with geometric verification. after_extraction: called once the features are in
    the database, before the matching."""
    pycolmap = import_pycolmap()

    ext = pycolmap.FeatureExtractionOptions()
    ext.sift.max_num_features = cfg.max_features
    # images are numbered first, in name order: extraction threads finish in any order, and the
    # mapper's result depends on the numbering. Each image's features do not depend on the
    # thread (tests/cues/test_cameras.py)
    ext.num_threads = SFM_THREADS
    ext.sift.estimate_affine_shape = few  # wide baselines between few views: affine + DSP SIFT
    ext.sift.domain_size_pooling = few
    pycolmap.Database.open(db).close()  # import_images needs the file to exist
    pycolmap.import_images(db, img_dir, camera_mode=pycolmap.CameraMode.PER_FOLDER, options=reader)
    if cfg.asift_per_view:
        asift_static_images(db, img_dir, Path(reader.mask_path), cfg.asift_per_view, moving or {})
    # COLMAP's extractor skips the images that have features already (the static ones with ASIFT)
    pycolmap.extract_features(db, img_dir, camera_mode=pycolmap.CameraMode.PER_FOLDER,
                              reader_options=reader, extraction_options=ext,
                              device=pycolmap.Device.cpu)
    if after_extraction is not None:
        after_extraction()
    mopt = pycolmap.FeatureMatchingOptions()
    mopt.num_threads = SFM_MATCH_THREADS
    verification = seeded_verification(seed)
    names = sorted(str(p.relative_to(img_dir)) for p in img_dir.glob("*/*.jpg"))
    pairs = sfm_image_pairs(names, moving or {}, SEQUENCE_OVERLAP)
    if len(pairs) == len(names) * (len(names) - 1) // 2:
        pycolmap.match_exhaustive(db, matching_options=mopt, verification_options=verification,
                                  device=pycolmap.Device.cpu)
    else:
        log.info("SIFT matching: %d of the %d image pairs (moving cameras' frames: sequential)",
                 len(pairs), len(names) * (len(names) - 1) // 2)
        pairing = pycolmap.ImportedPairingOptions()
        pairing.match_list_path = str(write_pairs(db.parent / "pairs.txt", pairs))
        pycolmap.match_image_pairs(db, matching_options=mopt, pairing_options=pairing,
                                   verification_options=verification, device=pycolmap.Device.cpu)
    guided_rematch(db, mopt.sift, verification)


def asift_static_images(db: Path, img_dir: Path, mask_dir: Path, per_view: int,
                         moving: dict[str, bool]) -> None:
    """ASIFT features (registration.affine_sift, per_view per simulated view) of every static
    video's images written into the database, in COLMAP's form: cameras far apart around one floor
    see it foreshortened along different headings, and SIFT matches almost none of it."""
    pycolmap = import_pycolmap()

    from .registration import affine_sift

    database = pycolmap.Database.open(db)
    try:
        for im in sorted(database.read_all_images(), key=lambda im: im.image_id):
            if moving.get(im.name.split("/")[0], False):
                continue
            grey = cv2.imread(str(img_dir / im.name), cv2.IMREAD_GRAYSCALE)
            mask = cv2.imread(str(mask_dir / (im.name + ".png")), cv2.IMREAD_GRAYSCALE)
            xy, desc = affine_sift(grey, mask, per_view)
            database.write_keypoints(im.image_id, xy + 0.5)  # COLMAP: pixel centres at +0.5
            database.write_descriptors(im.image_id,
                                       pycolmap.FeatureDescriptors(pycolmap.FeatureExtractorType.SIFT, desc))
            log.info("%s: %d ASIFT features", im.name, len(xy))
    finally:
        database.close()


def guided_rematch(db: Path, sift_options, verification) -> None:
    """Every verified pair matched again along its two-view geometry (COLMAP's guided matching,
    done by guided.py: its own took 10x the CPU for the same matches). A pair keeps its first
    matches when the guided ones are fewer than verification asks for."""
    pycolmap = import_pycolmap()

    config = pycolmap.TwoViewGeometryConfiguration
    by_f = {config.CALIBRATED, config.UNCALIBRATED}
    by_h = {config.PLANAR, config.PANORAMIC, config.PLANAR_OR_PANORAMIC}
    database = pycolmap.Database.open(db)
    try:
        pair_ids, geometries = database.read_two_view_geometries()
        todo = [(pycolmap.pair_id_to_image_pair(pid), g)
                for pid, g in zip(pair_ids, geometries) if g.config in by_f | by_h]
        ids = sorted({i for pair, _ in todo for i in pair})
        # copies: the arrays outlive pycolmap's objects and are read from other threads
        xy = {i: np.array(database.read_keypoints(i)[:, :2], np.float32) for i in ids}  # guided.py's type
        desc = {i: np.array(database.read_descriptors(i).data, np.uint8) for i in ids}

        def rematch(item):
            (a, b), g = item
            homography = g.config in by_h
            return guided_matches(xy[a], desc[a], xy[b], desc[b], g.H if homography else g.F, homography,
                                  verification.ransac.max_error, sift_options.max_ratio,
                                  sift_options.max_distance)

        # the kernel releases the GIL; each pair's matches do not depend on the thread. The first
        # pair runs alone so that numba compiles (or loads) the kernel once, not in every thread
        found = [rematch(item) for item in todo[:1]]
        with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
            found += pool.map(rematch, todo[1:])
        for ((a, b), g), m in zip(todo, found):
            if len(m) >= verification.min_num_inliers:
                g.inlier_matches = m.astype(np.uint32)
                database.update_two_view_geometry(a, b, g)
    finally:
        database.close()


def write_pairs(path: Path, pairs: list[tuple[str, str]]) -> Path:
    """COLMAP's image pair list: one "name_a name_b" per line."""
    path.write_text("".join(f"{a} {b}\n" for a, b in pairs))
    return path


def learned_database(features: str, db: Path, img_dir: Path, mask_dir: Path, reader, cfg: CameraConfig,
                      seed: int, moving: dict[str, bool] | None = None,
                      cancel=None) -> tuple[object, dict[int, np.ndarray]]:
    """Learned keypoints and their matches written into COLMAP's database, then COLMAP's geometric
    verification, so the mapper runs as with SIFT: XFeat (mutual nearest neighbours) or ALIKED with
    its LightGlue; the pairs of sfm_image_pairs. Returns the matcher and each image's descriptors
    (image id -> (N,D), in the order of its keypoints in the database), which the database does not
    hold. cancel: checked per image and per image pair."""
    pycolmap = import_pycolmap()

    from ..features import FEATURES

    pycolmap.Database.open(db).close()  # import_images needs the file to exist
    pycolmap.import_images(db, img_dir, camera_mode=pycolmap.CameraMode.PER_FOLDER, options=reader)
    matcher = FEATURES[features].matcher(top_k=cfg.max_features)
    database = pycolmap.Database.open(db)
    try:
        feats = {}
        images = sorted(database.read_all_images(), key=lambda im: im.image_id)
        for im in images:
            if cancel is not None:
                cancel.check()
            img = cv2.imread(str(img_dir / im.name))
            mask = cv2.imread(str(mask_dir / (im.name + ".png")), cv2.IMREAD_GRAYSCALE)
            feats[im.image_id] = matcher.features(img, None if mask is None else mask > 0)
            # COLMAP: pixel centres at +0.5
            database.write_keypoints(im.image_id, feats[im.image_id].keypoints.astype(np.float32) + 0.5)
        lines = []
        by_name = {im.name: im for im in images}
        for na, nb in sfm_image_pairs([im.name for im in images], moving or {}, SEQUENCE_OVERLAP):
            if cancel is not None:
                cancel.check()
            a, b = by_name[na], by_name[nb]
            m = matcher.match(feats[a.image_id], feats[b.image_id])
            if len(m):
                database.write_matches(a.image_id, b.image_id, m.astype(np.uint32))
                lines.append((a.name, b.name))
    finally:
        database.close()
    pycolmap.verify_matches(db, write_pairs(db.parent / "pairs.txt", lines), options=seeded_verification(seed))
    return matcher, {iid: f.descriptors for iid, f in feats.items()}


def image_pair_matches(db: Path) -> tuple:
    """Matches and geometrically verified matches of every matched SfM image pair (the recording
    and result.json show them: which frames of which videos the reconstruction could tie)."""
    pycolmap = import_pycolmap()

    database = pycolmap.Database.open(db)
    try:
        names = {im.image_id: im.name for im in database.read_all_images()}
        raw = dict(zip(*database.read_all_matches()))
        verified = {pid: len(g.inlier_matches) for pid, g in zip(*database.read_two_view_geometries())}
    finally:
        database.close()
    out = []
    for pid in sorted(set(raw) | set(verified)):
        a, b = pycolmap.pair_id_to_image_pair(pid)
        out.append({"a": names.get(a, str(a)), "b": names.get(b, str(b)),
                    "matches": int(len(raw.get(pid, ()))), "verified": int(verified.get(pid, 0))})
    log.info("SfM image pairs (matches/verified): %s",
             ", ".join(f"{p['a']}-{p['b']} {p['matches']}/{p['verified']}" for p in out))
    return tuple(out)


def log_into(pycolmap, folder: Path) -> None:
    """Send pycolmap's (glog) log files into `folder` instead of $TMPDIR, and its thousands of
    lines per reconstruction off stderr unless debug logging is on (`-vv`): pycolmap sets
    alsologtostderr. Each level gets its own file name: glog names a file prefix + time + pid,
    and a second level on the same name fails ("Could not create log file: File exists")."""
    try:
        pycolmap.logging.log_dir = str(folder)
        pycolmap.logging.alsologtostderr = log.isEnabledFor(logging.DEBUG)
        for level in (pycolmap.logging.INFO, pycolmap.logging.WARNING, pycolmap.logging.ERROR):
            pycolmap.logging.set_log_destination(level, str(folder / f"colmap.{level.name}."))
    except (AttributeError, TypeError):  # an older pycolmap without these controls
        pass


@contextlib.contextmanager
def scratch(workdir: str | None):
    """A scratch folder for one reconstruction (images, masks, database, COLMAP's logs), removed
    afterwards."""
    tmp = Path(tempfile.mkdtemp(prefix="vs_inspect_sfm_", dir=workdir))
    signals.register_temporary(tmp)  # removed also when the process is ended from the watchdog
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        signals.unregister_temporary(tmp)


