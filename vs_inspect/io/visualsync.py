"""Import cues made by the VisualSync paper's tools (CoTracker tracks, MASt3R-filtered cross-view
pairs, VGGT cameras) into a cue bundle.

Folder layout read by :func:`import_visualsync` (one sub-folder per video; the folder name is the
video name)::

    DIR/
      <video>/tracks.pkl               CoTracker output, a pickled dict:
                                         pred_tracks        (T,N,2) px (or (1,T,N,2))
                                         pred_visibilities  (T,N) bool or probability (or (1,T,N))
                                         or pred_valid      (T,N) bool
                                       numpy arrays or torch tensors
      <video>/camera_parameters.npz    VGGT cameras: c2w (F,4,4) camera-to-world, K (F,3,3) px in
                                       the tracks' pixel frame, valid (F,) bool; F = T, or F = 1
      <video>/<anything>.mp4|mov|...   optional: the video itself (size and per-frame times)
      pairs/<a>__<b>.npz               filtered_corr_indices (P,2) int: (track in a, track in b)

Frame times come from the video file when there is one, else from ``fps`` (k / fps). Without a
video file the image size is taken from K's principal point (2·(c + 0.5)). Cameras:
cam_from_world = inv(c2w); a camera whose valid poses are all equal within a tolerance is
static, otherwise it gets per-frame poses (invalid frames keep the nearest valid pose and are
marked invalid). Instead of VGGT cameras, an imported calibration may be given (its distortion
is then removed from the tracks).
"""

from __future__ import annotations

import io
import logging
import pickle
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo
from .video import VIDEO_SUFFIXES, open_video

log = logging.getLogger(__name__)

TRACKS_FILE = "tracks.pkl"
CAMERAS_FILE = "camera_parameters.npz"
PAIRS_DIR = "pairs"


@dataclass(frozen=True)
class ImportConfig:
    fps: float | None = None
    """Frame rate of videos without a video file in their folder (frame k at k / fps)."""
    visibility_threshold: float = 0.5
    """A track point counts as seen when its visibility (probability) is above this."""
    static_rotation_deg: float = 0.05
    """A camera whose poses all agree within this rotation ..."""
    static_translation: float = 1e-4
    """... and this translation (relative to the camera's distance from the origin, min 1)
    is imported as static."""


# ---- restricted unpickling ---------------------------------------------------------------------


def _safe_torch_load_from_bytes(b: bytes):
    # torch.storage._load_from_bytes calls torch.load(weights_only=False), which runs any code a
    # pickle names; the same bytes loaded with weights_only=True only rebuild tensors.
    import torch

    return torch.load(io.BytesIO(b), weights_only=True, map_location="cpu")


class _RestrictedUnpickler(pickle.Unpickler):
    """Unpickles only plain containers, numpy arrays/scalars and torch tensors.

    A pickle is a program: ``pickle.load`` calls whatever functions the file names, so a tracks
    file from the internet could run arbitrary code. Tracks need nothing but arrays, so every
    other global is refused.
    """

    _NUMPY = {
        ("numpy", "ndarray"), ("numpy", "dtype"),
        ("numpy._core.multiarray", "_reconstruct"), ("numpy.core.multiarray", "_reconstruct"),
        ("numpy._core.multiarray", "scalar"), ("numpy.core.multiarray", "scalar"),
        ("numpy._core.numeric", "_frombuffer"), ("numpy.core.numeric", "_frombuffer"),
    }
    _BUILTINS = {("collections", "OrderedDict"), ("builtins", "set"), ("builtins", "frozenset"),
                 ("builtins", "slice"), ("builtins", "complex")}
    _TORCH = {("torch._utils", "_rebuild_tensor_v2"), ("torch._utils", "_rebuild_tensor"),
              ("torch", "Size")}

    def find_class(self, module: str, name: str):
        if (module, name) in self._NUMPY or (module, name) in self._BUILTINS:
            return super().find_class(module, name)
        if module == "numpy.dtypes" and name.endswith("DType"):
            return super().find_class(module, name)
        if (module, name) in self._TORCH or (module, name) == ("torch.storage", "_load_from_bytes"):
            try:
                import torch  # noqa: F401
            except ImportError:
                raise pickle.UnpicklingError(
                    "the file holds torch tensors and torch is not installed; save the arrays "
                    "with numpy (tensor.cpu().numpy()) or install torch") from None
            if name == "_load_from_bytes":
                return _safe_torch_load_from_bytes
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"refused to load {module}.{name} (only arrays are allowed)")


def load_pickle_restricted(path) -> object:
    """Load a pickle (or a torch.save zip) that may hold only containers and arrays."""
    path = Path(path)
    try:
        if zipfile.is_zipfile(path):  # torch.save's format
            try:
                import torch
            except ImportError:
                raise InputError(f"{path}: a torch.save file needs torch installed") from None
            return torch.load(path, weights_only=True, map_location="cpu")
        with open(path, "rb") as f:
            return _RestrictedUnpickler(f).load()
    except InputError:
        raise
    except FileNotFoundError:
        raise InputError(f"{path}: missing file") from None
    except Exception as exc:  # noqa: BLE001 - any failure to unpickle is bad input
        raise InputError(f"{path}: cannot read ({type(exc).__name__}: {exc})") from None


def _to_numpy(x) -> np.ndarray:
    if hasattr(x, "detach"):  # torch tensor
        x = x.detach().cpu()
        if str(x.dtype) == "torch.bfloat16":
            x = x.float()
        x = x.numpy()
    return np.asarray(x)


# ---- per-file readers --------------------------------------------------------------------------


def read_cotracker(path, visibility_threshold: float = 0.5) -> Tracks:
    """CoTracker output -> Tracks with xy (N,T,2), NaN where the point is not visible."""
    path = Path(path)
    data = load_pickle_restricted(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a dict with 'pred_tracks', got {type(data).__name__}")
    if "pred_tracks" not in data:
        raise InputError(f"{path}: missing 'pred_tracks' (has {sorted(map(str, data))})")
    xy = _to_numpy(data["pred_tracks"]).astype(np.float64)
    if xy.ndim == 4 and xy.shape[0] == 1:
        xy = xy[0]
    if xy.ndim != 3 or xy.shape[2] != 2:
        raise InputError(f"{path}: pred_tracks must have shape (T,N,2) or (1,T,N,2), "
                         f"got {_to_numpy(data['pred_tracks']).shape}")
    T, N = xy.shape[:2]
    vis_key = "pred_visibilities" if "pred_visibilities" in data else \
        "pred_valid" if "pred_valid" in data else None
    if vis_key is None:
        log.warning("%s: no pred_visibilities or pred_valid: every point counts as seen", path)
        seen = np.ones((T, N), bool)
    else:
        vis = _to_numpy(data[vis_key])
        if vis.ndim == 3 and vis.shape[0] == 1:
            vis = vis[0]
        if vis.ndim == 3 and vis.shape[-1] == 1:
            vis = vis[..., 0]
        if vis.shape != (T, N):
            raise InputError(f"{path}: {vis_key} must have shape ({T},{N}) like pred_tracks, "
                             f"got {vis.shape}")
        seen = vis.astype(bool) if vis.dtype == bool else vis.astype(np.float64) > visibility_threshold
    seen &= np.all(np.isfinite(xy), axis=2)
    xy[~seen] = np.nan
    return Tracks(np.ascontiguousarray(xy.transpose(1, 0, 2)))


_NUMBER_ARRAYS = frozenset({"pred_tracks", "c2w", "K", "filtered_corr_indices"})


def _load_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise InputError(f"{path}: missing file") from None
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"{path}: not a readable .npz file ({exc})") from None
    for k, a in arrays.items():  # numbers (bool only for visibility and validity flags)
        allowed = "iuf" if k in _NUMBER_ARRAYS else "biuf"
        if a.dtype.hasobject or a.dtype.fields is not None or a.dtype.kind not in allowed:
            kind = {"c": "complex", "b": "bool", "U": "string", "S": "bytes"}.get(a.dtype.kind, str(a.dtype))
            raise InputError(f"{path}: {k} has dtype {kind}; need numbers")
    return arrays


def _orthonormalize(R: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(R)
    D = np.ones((R.shape[0], 3))
    D[:, 2] = np.sign(np.linalg.det(U @ Vt))
    return np.einsum("nij,nj,njk->nik", U, D, Vt)


def read_vggt_cameras(path, num_frames: int, cfg: ImportConfig = ImportConfig()) -> CameraTrack:
    """VGGT camera_parameters.npz -> CameraTrack (static when all valid poses agree)."""
    path = Path(path)
    data = _load_npz(path)
    for key in ("c2w", "K"):
        if key not in data:
            raise InputError(f"{path}: missing array {key!r} (has {sorted(data)})")
    c2w = np.asarray(data["c2w"], dtype=np.float64)
    K = np.asarray(data["K"], dtype=np.float64)
    if c2w.ndim == 2:
        c2w = c2w[None]
    if K.ndim == 2:
        K = K[None]
    if c2w.ndim != 3 or c2w.shape[1:] not in ((4, 4), (3, 4)):
        raise InputError(f"{path}: c2w must have shape (F,4,4), got {c2w.shape}")
    if c2w.shape[1:] == (3, 4):
        c2w = np.concatenate([c2w, np.broadcast_to([[[0, 0, 0, 1.0]]], (len(c2w), 1, 4))], axis=1)
    if K.shape[1:] != (3, 3):
        raise InputError(f"{path}: K must have shape (F,3,3), got {K.shape}")
    F = len(c2w)
    if len(K) not in (1, F):
        raise InputError(f"{path}: K has {len(K)} frames but c2w has {F}")
    K = np.broadcast_to(K, (F, 3, 3)).copy()
    valid = np.asarray(data.get("valid", np.ones(F, bool))).astype(bool).reshape(-1)
    if valid.shape != (F,):
        raise InputError(f"{path}: valid must have shape ({F},), got {valid.shape}")
    valid &= np.all(np.isfinite(c2w.reshape(F, -1)), axis=1) & np.all(np.isfinite(K.reshape(F, -1)), axis=1)
    if not valid.any():
        raise InputError(f"{path}: no valid camera pose")
    dets = np.abs(np.linalg.det(np.where(valid[:, None, None], K, np.eye(3))))
    if np.any(dets < 1e-9):
        raise InputError(f"{path}: K is singular at frame {int(np.argmax(dets < 1e-9))}")
    R = c2w[:, :3, :3]
    err = np.abs(np.einsum("nij,nkj->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    if np.any(err[valid] > 1e-2):
        raise InputError(f"{path}: c2w rotation is not a rotation at frame "
                         f"{int(np.flatnonzero(valid & (err > 1e-2))[0])} (|RRᵀ-I| = {err.max():.2g})")
    c2w = c2w.copy()
    c2w[valid, :3, :3] = _orthonormalize(R[valid])
    cfw = np.linalg.inv(np.where(valid[:, None, None], c2w, np.eye(4)))
    # static camera?
    vi = np.flatnonzero(valid)
    R0, t0, K0 = cfw[vi[0], :3, :3], cfw[vi[0], :3, 3], K[vi[0]]
    dR = np.einsum("nji,jk->nik", cfw[vi, :3, :3], R0)  # R_iᵀ R_0
    ang = np.degrees(np.arccos(np.clip((np.trace(dR, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    scale = max(1.0, float(np.linalg.norm(c2w[vi[0], :3, 3])))
    dt = np.linalg.norm(cfw[vi, :3, 3] - t0, axis=1) / scale
    dK = np.abs(K[vi] - K0).max() / max(1.0, K0[0, 0])
    if ang.max() <= cfg.static_rotation_deg and dt.max() <= cfg.static_translation and dK <= 1e-6:
        return CameraTrack(K0, cfw[vi[0]])
    if F != num_frames:
        raise InputError(f"{path}: {F} per-frame poses (a moving camera) but the tracks have "
                         f"{num_frames} frames")
    # invalid frames take the nearest valid pose so every array stays finite
    nearest = vi[np.abs(np.arange(F)[:, None] - vi[None, :]).argmin(axis=1)]
    cfw = cfw[nearest]
    K = K[nearest]
    K_out = K[0] if np.abs(K - K[0]).max() <= 1e-6 * max(1.0, K[0, 0, 0]) else K
    return CameraTrack(K_out, cfw, None if valid.all() else valid)


def read_pair_indices(path) -> np.ndarray:
    path = Path(path)
    data = _load_npz(path)
    if "filtered_corr_indices" not in data:
        raise InputError(f"{path}: missing array 'filtered_corr_indices' (has {sorted(data)})")
    idx = np.asarray(data["filtered_corr_indices"])
    if idx.size == 0:
        return np.zeros((0, 2), np.int64)
    if idx.ndim != 2 or idx.shape[1] != 2:
        raise InputError(f"{path}: filtered_corr_indices must have shape (P,2), got {idx.shape}")
    if not np.issubdtype(idx.dtype, np.integer):
        if not np.all(np.isfinite(idx)) or np.any(idx != np.round(idx)):
            raise InputError(f"{path}: filtered_corr_indices must be integers")
        idx = idx.astype(np.int64)
    return idx.astype(np.int64)


# ---- the whole folder ---------------------------------------------------------------------------


def _video_file(folder: Path) -> Path | None:
    files = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES)
    if len(files) > 1:
        raise InputError(f"{folder}: more than one video file {[p.name for p in files]}")
    return files[0] if files else None


def import_visualsync(folder, cfg: ImportConfig = ImportConfig(), calibration=None) -> CueBundle:
    """Read a folder in the layout of the module docstring into a CueBundle.

    calibration: optional {video name: CameraCalibration} used instead of VGGT cameras (tracks
    are undistorted with it).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such folder")
    vdirs = sorted(p for p in folder.iterdir() if p.is_dir() and (p / TRACKS_FILE).is_file())
    if not vdirs:
        raise InputError(f"{folder}: no video folders with {TRACKS_FILE} (expected "
                         f"{folder}/<video>/{TRACKS_FILE})")
    names = [p.name for p in vdirs]
    for bad in ("__",):
        clash = [n for n in names if bad in n]
        if clash:
            raise InputError(f"{folder}: video names may not contain '__' (used in pair file "
                             f"names): {clash}")
    videos, cameras, tracks = [], {}, {}
    for vdir in vdirs:
        name = vdir.name
        info, cam, tr = _import_video(vdir, cfg, calibration)
        videos.append(info)
        cameras[name] = cam
        tracks[name] = tr
    pairs = _read_pairs(folder, names, tracks)
    if not pairs:
        log.warning("%s: no cross-view pairs (%s/<a>__<b>.npz); nothing can be synchronized",
                    folder, PAIRS_DIR)
    try:
        return CueBundle(tuple(videos), cameras, tracks, pairs)
    except ValueError as exc:
        raise InputError(f"{folder}: {exc}") from None


def _import_video(vdir: Path, cfg: ImportConfig, calibration) -> tuple[VideoInfo, CameraTrack, Tracks]:
    """(its clock and size, its camera, its tracks) of one video folder: the tracks from
    tracks.pkl, the frame times from its video file (else cfg.fps), the camera from calibration
    (the tracks undistorted with it) or else from VGGT's camera_parameters.npz."""
    name = vdir.name
    tr = read_cotracker(vdir / TRACKS_FILE, cfg.visibility_threshold)
    T = tr.num_frames
    vfile = _video_file(vdir)
    info = None
    if vfile is not None:
        info = open_video(vfile, name=name).info
        if info.num_frames != T:
            raise InputError(f"{vfile}: video has {info.num_frames} frames but "
                             f"{vdir / TRACKS_FILE} tracks {T}")
    elif cfg.fps is None:
        raise InputError(f"{vdir}: no video file to take frame times from; give --fps")
    if calibration is not None:
        from .calibration import fit_to_video, to_camera_track, undistort_points
        if name not in calibration:
            raise InputError(f"no calibration for video {name!r}")
        cal = calibration[name]
        if info is not None:
            cal = fit_to_video(cal, info.width, info.height, name=f"{vfile}")
        tr = Tracks(undistort_points(cal, tr.xy), tr.instance)
        cam = to_camera_track(cal)
        size = cal.size
    else:
        cam_path = vdir / CAMERAS_FILE
        if not cam_path.is_file():
            raise InputError(f"{cam_path}: missing (VGGT cameras), and no calibration given")
        cam = read_vggt_cameras(cam_path, T, cfg)
        size = None
    if info is None:
        if size is None:  # the principal point is the best guess of the image centre
            K0 = cam.K if cam.K.ndim == 2 else cam.K[0]
            size = (int(round(2 * (K0[0, 2] + 0.5))), int(round(2 * (K0[1, 2] + 0.5))))
        try:
            info = VideoInfo.constant_rate(name, max(size[0], 1), max(size[1], 1), T, cfg.fps)
        except ValueError as exc:
            raise InputError(f"{vdir}: {exc}") from None
    log.info("%s: %d tracks over %d frames, %s camera", name, tr.num_tracks, T,
             "moving" if cam.is_moving else "static")
    return info, cam, tr


def _read_pairs(folder: Path, names: list[str], tracks: dict[str, Tracks]) -> dict[tuple[str, str], TrackPairs]:
    """pairs/<a>__<b>.npz (none without the folder), each pair given once, its track indices in
    range of both videos' tracks."""
    pairs: dict[tuple[str, str], TrackPairs] = {}
    pdir = folder / PAIRS_DIR
    if pdir.is_dir():
        for f in sorted(pdir.glob("*.npz")):
            parts = f.stem.split("__")
            if len(parts) != 2 or parts[0] not in names or parts[1] not in names:
                raise InputError(f"{f}: pair files are named <a>__<b>.npz with a, b among {names}")
            a, b = parts
            idx = read_pair_indices(f)
            for col, n in ((0, a), (1, b)):
                nt = tracks[n].num_tracks
                if len(idx) and (idx[:, col].min() < 0 or idx[:, col].max() >= nt):
                    raise InputError(f"{f}: track index out of range for {n!r} with {nt} tracks")
            if (b, a) in pairs:
                raise InputError(f"{f}: pairs for {a} and {b} are given twice ({b}__{a}.npz too)")
            pairs[(a, b)] = TrackPairs(a, b, idx)
    return pairs
