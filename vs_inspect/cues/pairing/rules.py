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
