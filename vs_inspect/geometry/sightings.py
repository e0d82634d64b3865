"""A worn camera seen by another camera: a timing cue from one point per frame.

A head-worn camera (glasses, a head mount) sits between its wearer's eyes. When camera b's wearer
is in camera a's view, the head that a sees at its local time t is where b's camera centre was at
that same moment. With both cameras' poses in one world (one reconstruction), the distance
between a's head detection and the projection of b's centre at b's local time t − Δ is a
landscape in Δ = offset_b − offset_a (DESIGN.md's convention) whose minimum is the true offset.
It needs no cross-view matching: the head is found in a alone, and b contributes its own poses.
Pure geometry, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._shapes import check_shape
from .epipolar import camera_centers, project
from .timing import frame_brackets


@dataclass(frozen=True)
class SightingLandscape:
    """Where camera a's head detections sit against camera b's projected centre, per candidate Δ."""

    offsets_s: np.ndarray  # (D,) candidate Δ = offset_b − offset_a, s
    moments: np.ndarray  # (D,) int, a's frames with a head, a pose, and b's centre (posed) in front of a
    near: np.ndarray  # (D,) int, of those moments: head within radius_px of b's projected centre
    median_px: np.ndarray  # (D,) median head-to-centre distance over the moments, px (NaN: none)
    radius_px: float  # the radius of `near`, px


def _centre_seen(timestamps_a_s: np.ndarray, K_a: np.ndarray, cam_from_world_a: np.ndarray,
                 timestamps_b_s: np.ndarray, cam_from_world_b: np.ndarray, valid_b: np.ndarray,
                 offsets_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((D,T_a,2) b's centre projected into a at b's time t − Δ, NaN behind a; (D,T_a) bool, b
    posed then: inside its clip, both bracketing frames valid). b's centre is interpolated linearly
    between its frames."""
    ts_b = np.asarray(timestamps_b_s, np.float64)
    centres_b = camera_centers(cam_from_world_b)  # (T_b,3)
    k, w = frame_brackets(ts_b, np.asarray(timestamps_a_s, np.float64)[None, :] - offsets_s[:, None])  # (D,T_a)
    inside = k >= 0
    k0 = np.where(inside, k, 0)
    k1 = np.minimum(k0 + 1, len(ts_b) - 1)
    posed = inside & valid_b[k0] & valid_b[k1]
    centre = (1 - w)[..., None] * centres_b[k0] + w[..., None] * centres_b[k1]
    return project(np.asarray(K_a, np.float64), cam_from_world_a[None], centre), posed


def _checked_inputs(head_xy_a, timestamps_a_s, cam_from_world_a, valid_a, timestamps_b_s, cam_from_world_b, valid_b,
                    radius_px: float):
    """The arrays as float64 / bool, their shapes and the radius checked (ValueError naming the
    wrong one)."""
    if not radius_px > 0:
        raise ValueError(f"radius_px must be positive, got {radius_px}")
    T_a = len(check_shape("timestamps_a_s", np.asarray(timestamps_a_s, np.float64), (None,), batched=False))
    head = check_shape("head_xy_a", np.asarray(head_xy_a, np.float64), (T_a, 2), batched=False)
    pose_a = check_shape("cam_from_world_a", np.asarray(cam_from_world_a, np.float64), (T_a, 4, 4), batched=False)
    ts_b = check_shape("timestamps_b_s", np.asarray(timestamps_b_s, np.float64), (None,), batched=False)
    pose_b = check_shape("cam_from_world_b", np.asarray(cam_from_world_b, np.float64), (len(ts_b), 4, 4),
                         batched=False)
    valid_a = check_shape("valid_a", np.asarray(valid_a, bool), (T_a,), batched=False)
    valid_b = check_shape("valid_b", np.asarray(valid_b, bool), (len(ts_b),), batched=False)
    return head, pose_a, valid_a, ts_b, pose_b, valid_b


def sighting_landscape(head_xy_a: np.ndarray, timestamps_a_s: np.ndarray, K_a: np.ndarray,
                       cam_from_world_a: np.ndarray, valid_a: np.ndarray, timestamps_b_s: np.ndarray,
                       cam_from_world_b: np.ndarray, valid_b: np.ndarray, offsets_s: np.ndarray,
                       radius_px: float) -> SightingLandscape:
    """Landscape of camera b's wearer seen by camera a.

    head_xy_a: (T_a,2) undistorted px of the head a sees (NaN: none); timestamps_*_s: (T,) local
    frame times, s; K_a: (3,3); cam_from_world_*: (T,4,4) per-frame poses in one world, valid_*:
    (T,) bool; offsets_s: (D,) candidates Δ. b's centre is interpolated linearly between its frames.
    """
    head, pose_a, valid_a, ts_b, pose_b, valid_b = _checked_inputs(
        head_xy_a, timestamps_a_s, cam_from_world_a, valid_a, timestamps_b_s, cam_from_world_b, valid_b, radius_px)
    offsets = np.asarray(offsets_s, np.float64).reshape(-1)
    seen, posed = _centre_seen(timestamps_a_s, K_a, pose_a, ts_b, pose_b, valid_b, offsets)
    dist = np.linalg.norm(seen - head[None], axis=-1)
    use = posed & valid_a[None] & np.isfinite(dist)
    moments = use.sum(1)
    near = (use & (dist < radius_px)).sum(1)
    with np.errstate(all="ignore"):
        median = np.array([np.median(d[u]) if u.any() else np.nan for d, u in zip(dist, use)])
    return SightingLandscape(offsets, moments.astype(int), near.astype(int), median, float(radius_px))


@dataclass(frozen=True)
class SightingShiftFit:
    """The chosen heads against b's projected centre plus one constant image shift, per candidate Δ:
    the least-squares fit of Δ and the shift together (the head is not the camera centre)."""

    offsets_s: np.ndarray  # (D,) candidate Δ = offset_b − offset_a, s
    chosen: np.ndarray  # (T_a,) bool, a's heads taken as b's wearer
    moments: np.ndarray  # (D,) int, of the chosen heads: those b's centre is posed for at Δ
    shift_px: np.ndarray  # (D,2) mean head − projected centre over those moments, px (NaN: none)
    sum_sq_px2: np.ndarray  # (D,) sum of squared distances of head − centre from that mean, px²


def sighting_shift_fit(head_xy_a: np.ndarray, timestamps_a_s: np.ndarray, K_a: np.ndarray,
                       cam_from_world_a: np.ndarray, valid_a: np.ndarray, timestamps_b_s: np.ndarray,
                       cam_from_world_b: np.ndarray, valid_b: np.ndarray, offsets_s: np.ndarray,
                       peak_s: float, radius_px: float) -> SightingShiftFit:
    """How well b's projected centre at t − Δ, shifted by one constant vector, explains a's heads
    taken as b's wearer (those within radius_px of the centre at Δ = peak_s, a landscape's peak),
    per candidate Δ (the other arguments as sighting_landscape).

    A worn camera is not where the detector puts the head (Aria's camera sits at the frame's
    corner, the face a few cm away), so heads sit a few px to one side of the centre. While the
    wearer moves one way, the offset that brings the centre nearest the heads is then a frame or
    so off; leaving the shift free takes that side out of Δ.
    """
    head, pose_a, valid_a, ts_b, pose_b, valid_b = _checked_inputs(
        head_xy_a, timestamps_a_s, cam_from_world_a, valid_a, timestamps_b_s, cam_from_world_b, valid_b, radius_px)
    offsets = np.asarray(offsets_s, np.float64).reshape(-1)
    seen, posed = _centre_seen(timestamps_a_s, K_a, pose_a, ts_b, pose_b, valid_b,
                               np.concatenate([[float(peak_s)], offsets]))
    with np.errstate(invalid="ignore"):
        chosen = posed[0] & valid_a & (np.linalg.norm(seen[0] - head, axis=-1) < radius_px)
    seen, posed = seen[1:], posed[1:]
    diff = head[None] - seen  # (D,T_a,2)
    use = posed & chosen[None] & np.isfinite(diff).all(-1)
    n = use.sum(1)
    diff = np.where(use[..., None], diff, 0.0)
    with np.errstate(all="ignore"):
        shift = diff.sum(1) / n[:, None]
    dev = np.where(use, np.sum((diff - np.nan_to_num(shift)[:, None]) ** 2, -1), 0.0).sum(1)
    return SightingShiftFit(offsets, chosen, n.astype(int), shift, np.where(n > 0, dev, np.nan))


def sighting_peak(offsets_s: np.ndarray, near: np.ndarray, exclude_s: float) -> tuple[float, int, int, int]:
    """(peak Δ s, first and last index of its plateau, rival): the peak is the middle of the run of
    candidates around the first maximum of near (D,) that share its count (a plateau has no sharper
    point); the rival is the largest count farther than exclude_s from the peak."""
    near = np.asarray(near)
    top = int(near.max()) if len(near) else 0
    lo = hi = int(np.argmax(near)) if len(near) else 0
    while lo > 0 and near[lo - 1] == top:
        lo -= 1
    while hi < len(near) - 1 and near[hi + 1] == top:
        hi += 1
    peak = float(0.5 * (offsets_s[lo] + offsets_s[hi]))
    far = np.abs(np.asarray(offsets_s) - peak) > exclude_s
    return peak, lo, hi, int(near[far].max()) if far.any() else 0
