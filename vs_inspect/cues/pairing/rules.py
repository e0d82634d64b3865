"""Stage 0's acceptance rules on the joint vote of one camera set, each a named function."""

from __future__ import annotations

from .joint import JointChoice
from .votes import GeometricPairStats, votes_at


def joint_vote_share(st: GeometricPairStats, delta_s: float) -> float:
    """The pair's votes at Δ_ab = delta_s (candidates whose best offset lies within halfwidth_s)
    over the votes of its own highest peak: 1 when the joint choice takes the pair's top peak,
    near 0 when the pair votes for another Δ and hardly at all for this one (1 with no votes)."""
    if st.cand_offset_s is None or not st.peak_votes or max(st.peak_votes) <= 0:
        return 1.0
    return min(1.0, votes_at(st, delta_s) / max(st.peak_votes))


def disputed_by_other_model(joint: JointChoice, sure: dict[str, bool],
                            other_peaks: dict[tuple[str, str], tuple[float, ...]], tol_s: float,
                            other: str = "the other camera model", three_view_share: dict[str, float] | None = None,
                            overrule_share: float | None = None) -> tuple[dict[str, str], dict[str, str]]:
    """Sure cameras whose joint offsets the vote peaks of another camera model contradict:
    ({camera: reason} disputed, {camera: reason} whose dispute its own three-view check overrules).

    other_peaks: (a, b) -> the vote peaks Δ_ab (s) of the pair with the other model's cameras.
    A sure camera is kept when one of its pairs with another sure camera has a peak of the other
    model within tol_s of the joint Δ_ab; a camera none of whose such pairs the other model voted
    on has no opinion against it and is kept. Two reconstructions from different features
    rarely err alike, so a wrong camera of one model (even one that passes its three-view check)
    tends to find no peak of the other model near its joint Δ, while right cameras do.

    three_view_share: camera -> trajectories its tracks follow at its joint offset over those
    followed at its best offset (transfer.ThreeViewCheck). A contradicted camera with at least
    overrule_share (None: none) is kept, its dispute overruled: the other model's cameras can be the wrong
    ones (measured: see BENCHMARKS.md, "Measurements behind defaults")."""
    out: dict[str, str] = {}
    overruled: dict[str, str] = {}
    for cam in sorted(n for n, ok in sure.items() if ok):
        voted = {}
        for (a, b), peaks in other_peaks.items():
            if cam in (a, b) and sure.get(a) and sure.get(b) and len(peaks):
                voted[(a, b)] = (joint.offsets_s[b] - joint.offsets_s[a], peaks)
        if voted and not any(min(abs(p - d) for p in peaks) <= tol_s for d, peaks in voted.values()):
            why = (f"{other}'s vote peaks of its pairs lie more than {tol_s:.3f} s from the joint Δ: "
                   + "; ".join(f"{a}__{b} Δ {d:+.3f} s, peaks {', '.join(f'{p:+.3f}' for p in peaks)} s"
                               for (a, b), (d, peaks) in sorted(voted.items())))
            share = (three_view_share or {}).get(cam)
            if share is not None and overrule_share is not None and share >= overrule_share:
                overruled[cam] = (f"{why}; overruled: its three-view check follows {share:.2f} of its best "
                                  f"offset's trajectories at the joint offset (at least {overrule_share:g})")
            else:
                out[cam] = why
    return out, overruled


def rival_offsets(found: dict[tuple[str, str], GeometricPairStats], joint: JointChoice,
                  sure: dict[str, bool], three_view_best_s: dict[str, tuple[float, int, int]],
                  min_apart_s: float, min_share: float) -> dict[str, str]:
    """Sure cameras with a rival offset: {camera: reason}.

    three_view_best_s: camera -> (offset_s where its three-view check followed the most
    trajectories, how many there, how many at its joint offset). A rival is that offset when it
    lies more than min_apart_s from the joint offset with more trajectories followed, and every
    pair of the camera with another sure camera keeps at least min_share of its own top peak's
    votes at the Δ it implies (joint_vote_share). Three views then prefer the rival and the
    epipolar vote does not rule it out: a repeated motion lets the joint vote choose a set of
    peaks one period off that closes every triangle."""
    out = {}
    for cam, (best_s, n_best, n_joint) in sorted(three_view_best_s.items()):
        if not sure.get(cam) or n_best <= n_joint or abs(best_s - joint.offsets_s[cam]) <= min_apart_s:
            continue
        at = {**joint.offsets_s, cam: best_s}
        shares = {f"{a}__{b}": joint_vote_share(st, at[b] - at[a]) for (a, b), st in found.items()
                  if cam in (a, b) and sure.get(a) and sure.get(b)}
        if shares and min(shares.values()) >= min_share:
            out[cam] = (f"its three-view check follows {n_best} trajectories at {best_s:+.3f} s against "
                        f"{n_joint} at its joint offset {joint.offsets_s[cam]:+.3f} s, and its pairs keep "
                        + ", ".join(f"{k} {v:.2f}" for k, v in shares.items())
                        + f" of their top vote peaks' votes there (at least {min_share:g} each): two offsets, "
                        "as a repeated motion gives")
    return out
