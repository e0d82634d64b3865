"""Peer 1 (motion-signal cross-correlation): known shifts recovered from synthetic signals."""

import numpy as np

from vs_inspect.baselines.motion_xcorr import (motion_signal_from_frames, motion_signal_from_tracks,
                                               sync_motion_xcorr, xcorr_offset)
from vs_inspect.types import CameraTrack, CueBundle, Tracks, VideoInfo


def smooth_signal(seed: int):
    """f(g): a random smooth positive signal of global time g (sum of sines)."""
    rng = np.random.default_rng(seed)
    freq = rng.uniform(0.2, 2.0, 8)
    amp = rng.uniform(0.5, 1.0, 8)
    phase = rng.uniform(0, 2 * np.pi, 8)
    return lambda g: 10.0 + np.sum(amp[:, None] * np.sin(2 * np.pi * freq[:, None] * np.atleast_1d(g)[None] + phase[:, None]), 0)


def test_xcorr_recovers_a_known_shift_between_different_rates():
    f = smooth_signal(3)
    offset_a, offset_b = 0.4, 1.65  # global time of each video's local 0 (DESIGN.md)
    ta = np.arange(0, 8, 1 / 30)
    tb = np.arange(0, 7, 1 / 25)
    lags = np.arange(-4, 4, 1 / 30)
    r = xcorr_offset(ta, f(ta + offset_a), tb, f(tb + offset_b), lags, rate_hz=30.0)
    best = lags[np.nanargmax(r)]
    assert abs(best - (offset_b - offset_a)) <= 1 / 30 + 1e-9  # Δ_ab = offset_b - offset_a
    assert np.nanmax(r) > 0.99
    # the wrong sign is far from a peak
    assert r[np.argmin(np.abs(lags + (offset_b - offset_a)))] < 0.9


def test_xcorr_needs_overlap():
    t = np.arange(0, 2, 0.1)
    r = xcorr_offset(t, np.sin(t), t, np.sin(t), np.array([0.0, 1.5, 5.0]), 10.0, min_overlap_s=1.0)
    assert np.isfinite(r[0]) and np.isnan(r[1]) and np.isnan(r[2])


def test_frame_signal_is_zero_when_nothing_moves_and_grows_with_motion():
    frames = []
    for k in range(6):
        img = np.zeros((40, 60), np.uint8)
        x = 5 + (0 if k < 3 else 4 * (k - 2))  # still for 3 frames, then moving
        img[10:20, x:x + 10] = 255
        frames.append(img)
    ts = np.arange(6) / 10.0
    t, s = motion_signal_from_frames(frames, ts)
    assert np.allclose(t, (ts[1:] + ts[:-1]) / 2)
    assert np.all(s[:2] == 0) and np.all(s[2:] > 0)


def test_sync_motion_xcorr_recovers_offsets_of_three_videos():
    """One point whose speed follows f(g) in each video; the offsets come back through Stage 2."""
    f = smooth_signal(11)
    truth = {"a": 0.0, "b": 1.3, "c": -0.85}
    fps = {"a": 30.0, "b": 25.0, "c": 24.0}
    videos, tracks, cams = [], {}, {}
    g_fine = np.arange(-5, 15, 1e-3)
    x_of_g = np.cumsum(f(g_fine)) * 1e-3  # position = integral of the speed
    for n in truth:
        v = VideoInfo.constant_rate(n, 640, 480, int(6 * fps[n]), fps[n])
        g = v.timestamps_s + truth[n]
        xy = np.stack([np.interp(g, g_fine, x_of_g), np.full_like(g, 100.0)], -1)[None]
        videos.append(v)
        tracks[n] = Tracks(xy)
        cams[n] = CameraTrack(np.diag([500.0, 500.0, 1.0]), np.eye(4))
    bundle = CueBundle(tuple(videos), cams, tracks, {}, truth)
    t, s = motion_signal_from_tracks(videos[0], tracks["a"])
    assert np.allclose(s, f(t), rtol=0.05)
    res = sync_motion_xcorr(bundle)
    for n in truth:
        assert abs(res.offsets_s[n] - truth[n]) < 1 / 24, (n, res.offsets_s)
