"""Stage 0's typed records (vs_inspect.cue_stats) with the fields a test does not care about filled."""

from __future__ import annotations

from vs_inspect.cue_stats import (CueStats, JointVoteRecord, PairCueStats, PairVoteSummary, ThreeViewSummary,
                                  TransferSummary)


def joint(margin: dict, used=(), sure=(), origin: str | None = None, **checks) -> JointVoteRecord:
    """A joint vote record; checks: transfer / three_view ({camera: dict of the summary's fields}),
    dissent, dissent_short, overruled."""
    transfer = {c: TransferSummary(**{"joint_offset_s": 0.0, **t}) for c, t in (checks.pop("transfer", None) or {}).items()}
    three = {c: ThreeViewSummary(**{"joint_offset_s": 0.0, "trajectories": 0, "supporters": 0, "best_supporters": 0, **t})
             for c, t in (checks.pop("three_view", None) or {}).items()}
    return JointVoteRecord(origin or min(margin), dict.fromkeys(margin, 0.0), 0.0, dict(margin), tuple(sure),
                           tuple(used), transfer or None, three or None, **checks)


def withheld(why: str, short: str | None = None) -> PairCueStats:
    """A pair whose vote peaks were withheld with that reason."""
    return PairCueStats(0, 0, 0, 0, PairVoteSummary(0, 0, 0, 0, (), (), geometric_withheld=why,
                                                    geometric_withheld_short=short))


def cue_stats(source: str = "estimated", *, videos=None, pairs=None, dropped=None, peaks="joint", sfm=None,
              joint_vote=None, registered: int = 3, tracks: int = 10, track_pairs: int = 10) -> CueStats:
    return CueStats(source, registered, tracks, track_pairs, videos or {}, pairs or {}, dropped or {}, {}, peaks, sfm,
                    joint_vote)
