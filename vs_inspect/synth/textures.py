"""Procedural textures of the synthetic world (RGB uint8, row 0 = top of the image): ground,
walls, crates, cloth and balls, and unique marks that make a moving body's points tell apart."""

from __future__ import annotations

import cv2
import numpy as np


def value_noise(rng: np.random.Generator, h: int, w: int, octaves=(4, 16, 64, 256)) -> np.ndarray:
    """(h,w) float in about [-1,1]: smooth noise summed over grid sizes."""
    out = np.zeros((h, w), np.float32)
    amp = 1.0
    for cells in octaves:
        g = rng.standard_normal((max(2, cells * h // max(h, w)), max(2, cells * w // max(h, w))))
        out += amp * cv2.resize(g.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        amp *= 0.6
    return out / (np.abs(out).max() + 1e-9)


def _tint(gray: np.ndarray, rgb_lo, rgb_hi) -> np.ndarray:
    t = np.clip(gray, 0, 1)[..., None]
    return (np.asarray(rgb_lo) * (1 - t) + np.asarray(rgb_hi) * t).astype(np.uint8)


def ground_texture(rng: np.random.Generator, size: int = 2048, tiles: int = 24) -> np.ndarray:
    """Paving: 1 m tiles of varying shade, joints, noise and scattered marks."""
    yy, xx = np.mgrid[0:size, 0:size]
    cell = size / tiles
    shade = rng.uniform(0.35, 0.75, size=(tiles, tiles))
    g = shade[(yy // cell).astype(int), (xx // cell).astype(int)]
    g = g + 0.18 * value_noise(rng, size, size)
    joint = (np.mod(xx, cell) < 3) | (np.mod(yy, cell) < 3)
    g[joint] = 0.15
    img = _tint(g, (70, 62, 50), (215, 205, 185))
    for _ in range(400):  # marks: stones, leaves, paint spots
        c = tuple(int(v) for v in rng.integers(0, size, 2))
        col = tuple(int(v) for v in rng.integers(20, 235, 3))
        if rng.random() < 0.5:
            cv2.circle(img, c, int(rng.integers(3, 14)), col, -1, cv2.LINE_AA)
        else:
            d = rng.integers(-25, 25, 2)
            cv2.line(img, c, (c[0] + int(d[0]), c[1] + int(d[1])), col, int(rng.integers(2, 6)), cv2.LINE_AA)
    return img


def wall_texture(rng: np.random.Generator, w: int, h: int, base_rgb) -> np.ndarray:
    """Bricks of varying colour with mortar, plus posters and graffiti-like strokes."""
    img = np.zeros((h, w, 3), np.uint8)
    img[:] = (200, 200, 195)
    bh = h // 16
    bw = 2 * bh
    base = np.asarray(base_rgb, dtype=np.float64)
    for r in range(0, h // bh + 1):
        shift = (r % 2) * bw // 2
        for c in range(-1, w // bw + 2):
            col = np.clip(base * rng.uniform(0.7, 1.2) + rng.normal(0, 12, 3), 0, 255)
            x0, y0 = c * bw + shift, r * bh
            cv2.rectangle(img, (x0 + 2, y0 + 2), (x0 + bw - 2, y0 + bh - 2), tuple(float(v) for v in col), -1)
    noise = value_noise(rng, h, w, octaves=(8, 32, 128))
    img = np.clip(img.astype(np.float32) * (1 + 0.15 * noise[..., None]), 0, 255).astype(np.uint8)
    for _ in range(6):  # posters
        x0, y0 = int(rng.integers(0, w - h // 3)), int(rng.integers(0, h // 2))
        pw, ph = int(rng.integers(h // 6, h // 3)), int(rng.integers(h // 5, h // 2.5))
        col = tuple(int(v) for v in rng.integers(30, 250, 3))
        cv2.rectangle(img, (x0, y0), (x0 + pw, y0 + ph), col, -1)
        for _ in range(5):
            c2 = tuple(int(v) for v in rng.integers(0, 255, 3))
            p = (x0 + int(rng.integers(0, pw)), y0 + int(rng.integers(0, ph)))
            cv2.circle(img, p, int(rng.integers(4, max(5, pw // 4))), c2, -1, cv2.LINE_AA)
    return img


def crate_texture(rng: np.random.Generator, label: str, rgb, size: int = 512) -> np.ndarray:
    """3x2 atlas for box_mesh: planks with a frame and a painted label on every face."""
    H, W = size * 2, size * 3
    g = 0.55 + 0.25 * value_noise(rng, H, W, octaves=(6, 24, 96))
    img = _tint(g, np.asarray(rgb) * 0.45, np.minimum(255, np.asarray(rgb) * 1.2))
    for i in range(6):
        col, row = i % 3, i // 3
        x0, y0 = col * size, (1 - row) * size  # image rows go down, atlas v goes up
        for k in range(1, 5):
            cv2.line(img, (x0, y0 + k * size // 5), (x0 + size, y0 + k * size // 5), (40, 30, 20), 4)
        cv2.rectangle(img, (x0 + 12, y0 + 12), (x0 + size - 12, y0 + size - 12), (30, 25, 15), 18)
        cv2.line(img, (x0 + 12, y0 + 12), (x0 + size - 12, y0 + size - 12), (30, 25, 15), 14)
        cv2.putText(img, f"{label}{i}", (x0 + size // 6, y0 + 2 * size // 3), cv2.FONT_HERSHEY_DUPLEX,
                    size / 170, (240, 240, 240), max(2, size // 60), cv2.LINE_AA)
    return img


def cloth_texture(rng: np.random.Generator, rgb_a, rgb_b, size: int = 256, stripes: int = 8) -> np.ndarray:
    """Bold stripes with a checker overlay and noise (a shirt, trousers, a box)."""
    yy, xx = np.mgrid[0:size, 0:size]
    s = ((yy * stripes) // size) % 2
    chk = (((xx * stripes * 2) // size + (yy * stripes * 2) // size) % 2) * 0.25
    t = np.clip(s * 0.8 + chk + 0.15 * value_noise(rng, size, size, octaves=(4, 16, 64)), 0, 1)
    return _tint(t, rgb_a, rgb_b)


def ball_texture(rng: np.random.Generator, colours, size: int = 512) -> np.ndarray:
    """Beach-ball segments in longitude, a band at the equator and dots."""
    h, w = size // 2, size
    yy, xx = np.mgrid[0:h, 0:w]
    seg = (xx * len(colours) // w) % len(colours)
    img = np.asarray(colours, dtype=np.uint8)[seg]
    band = np.abs(yy - h / 2) < h / 14
    img[band] = (250, 250, 250)
    for _ in range(30):
        c = (int(rng.integers(0, w)), int(rng.integers(h // 8, 7 * h // 8)))
        cv2.circle(img, c, int(rng.integers(4, 12)), tuple(int(v) for v in rng.integers(0, 255, 3)), -1, cv2.LINE_AA)
    return img


def add_marks(img: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """A copy of img with n random small dots, rings and strokes: unique local features, so that
    repeated patterns (stripes, the same tile on every face) still match unambiguously."""
    out = img.copy()
    h, w = out.shape[:2]
    r_max = max(3, min(h, w) // 24)
    for _ in range(n):
        c = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        col = tuple(int(v) for v in rng.integers(0, 256, 3))
        kind = rng.integers(0, 3)
        if kind == 0:
            cv2.circle(out, c, int(rng.integers(2, r_max)), col, -1, cv2.LINE_AA)
        elif kind == 1:
            cv2.circle(out, c, int(rng.integers(3, r_max + 2)), col, 2, cv2.LINE_AA)
        else:
            d = rng.integers(-r_max, r_max + 1, 2)
            cv2.line(out, c, (c[0] + int(d[0]), c[1] + int(d[1])), col, 2, cv2.LINE_AA)
    return out

