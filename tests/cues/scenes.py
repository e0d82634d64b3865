"""Small synthetic image sequences drawn with OpenCV: a textured blob moving over a textured
background, optionally with a panning camera. Ground truth: the blob's mask and motion."""

from __future__ import annotations

import cv2
import numpy as np


def texture(h: int, w: int, seed: int, blur: float = 1.5) -> np.ndarray:
    """(h,w) uint8 random texture with corners and blobs (good for KLT and SIFT)."""
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 256, (h // 4 + 1, w // 4 + 1)).astype(np.uint8)
    img = cv2.resize(small, (w, h), interpolation=cv2.INTER_NEAREST)
    img = cv2.GaussianBlur(img, (0, 0), blur)
    for _ in range(max(4, h * w // 2000)):
        c = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        cv2.circle(img, c, int(rng.integers(2, 6)), int(rng.integers(0, 256)), -1)
    return img


def blob_sequence(T: int = 24, h: int = 160, w: int = 240, pan_px: float = 0.0, seed: int = 0,
                  blob_seed: int = 100, velocity=(3.0, 1.5), radius: int = 28, start=(60.0, 60.0)):
    """(frames (T,h,w) uint8, true masks (T,h,w) bool, blob offsets (T,2) px).

    The blob (a disc cut from its own texture, which moves with it) translates by `velocity`
    px per frame; the background translates by `pan_px` per frame in x (a panning camera).
    """
    big = texture(h, w + int(abs(pan_px) * T) + 8, seed)
    tex = texture(2 * radius + 1, 2 * radius + 1, blob_seed, blur=1.0)
    disc = np.zeros_like(tex)
    cv2.circle(disc, (radius, radius), radius, 255, -1)
    frames = np.empty((T, h, w), np.uint8)
    masks = np.zeros((T, h, w), bool)
    offs = np.zeros((T, 2))
    for t in range(T):
        x0 = int(round(pan_px * t))
        bg = big[:, x0:x0 + w].copy()
        cx, cy = start[0] + velocity[0] * t, start[1] + velocity[1] * t
        offs[t] = (cx, cy)
        M = np.float32([[1, 0, cx - radius], [0, 1, cy - radius]])
        warped = cv2.warpAffine(tex, M, (w, h), flags=cv2.INTER_LINEAR)
        m = cv2.warpAffine(disc, M, (w, h), flags=cv2.INTER_LINEAR) > 127
        bg[m] = warped[m]
        frames[t] = bg
        masks[t] = m
    return frames, masks, offs
