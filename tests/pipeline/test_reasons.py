"""Each null's reason in the user's terms (pipeline/reasons.py): what was missing and what to try,
one sentence per cause; the technical account follows it in result.json."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from vs_inspect.pipeline.reasons import plain_reason, with_plain_reason
from ..cue_records import joint as joint_vote
from vs_inspect.cue_stats import CueStats, VideoCueStats


def _stats(source="estimated", dropped=None, note=None, joint=None, pairs=None, people=None):
    videos = {"v": VideoCueStats("v.mp4", "static", 0.1, 0.0 if note else 0.1, 0 if note else 50, 1, 10, 5, note)}
    return CueStats(source, 3, 50, 10, videos, pairs or {}, dropped or {}, {}, "joint", None, joint, people=people)


def _people(dropped: str):
    """Stage 0's record when the people's cameras were used and `v` was left out for `dropped`."""
    from vs_inspect.cue_stats import PeopleRecord

    record = PeopleRecord(True, "the people alone were asked for", "r", {"r": 2, "v": 1}, {}, {"r": 0.0},
                          {"v": dropped}, {}, {})
    return _stats("estimated from people", dropped={"v": dropped}, people=record)


def _pair(reason, a="r", b="v"):
    return SimpleNamespace(a=a, b=b, decision=SimpleNamespace(reason=reason))


@pytest.mark.parametrize("stats, why, pairs, says", [
    (_stats(dropped={"v": "could not be read: corrupt"}), "", (), "the video could not be read; check"),
    (_stats(dropped={"v": "the only readable video: ..."}), "", (), "no other video could be read"),
    (_stats(note="no moving regions found"), "not connected", (), "nothing moving was found in it"),
    (_stats("calibration", dropped={"v": "the calibration has no camera for this video"}), "", (),
     "the calibration gives no usable camera for it"),
    (_stats(dropped={"v": "no reconstruction: too few matches"}), "", (),
     "its camera could not be placed from the background it shares with the other videos; try giving a "
     "calibration (--calib) or a video that shows more of that background"),
    (_people("a moving camera (its background moves 4.0 px between frames): the people cue fits ..."), "", (),
     "its camera moves, and the people in view time static cameras only"),
    (_people("no people found"), "", (), "no person was followed in it, and the background gave no camera"),
    (_people("no accepted pair of people links it to r (r__v: no person followed in r)"), "", (),
     "the people it shares with the other videos gave no clear time shift"),  # its partner had none
    (_people("no accepted pair of people links it to r (r__v: uncertain shift: from -8.80 to -8.40 s ...)"), "", (),
     "the people it shares with the other videos move too slowly to time it within a frame"),
    (_people("no accepted pair of people links it to r (r__v: ambiguous shift: ...)"), "", (),
     "the people it shares with the other videos gave no clear time shift"),
    (_stats(joint=joint_vote({"v": 3.3})), "not connected", (),
     "its offset could not be confirmed by a third camera; try giving a calibration (--calib), a rough "
     "offset window (--range-s or --around) or another camera that sees the same motion"),
    (_stats(joint=joint_vote({"v": 9.0}, dissent={"v": "x"},
                              dissent_short={"v": "two offsets 1.22 s apart, as a repeated motion gives"})), "", (),
     "the motion it sees repeats, so more than one offset fits"),
    (_stats(), "its offset would rest on 2 sightings of camera carriers in a chain from the reference", (),
     "its offset would rest on a chain of sightings of people carrying cameras"),
    (_stats(), "the reference, but no accepted pair links it", (), "it is the reference, but no other video"),
    (_stats(), "its accepted pairs contradict each other: ...", (), "its pairs with the other videos give offsets"),
    (_stats(), "connected to the reference only through c, ...", (), "it is linked to the reference only through"),
    (_stats(), "not connected", (_pair("best minimum at the edge of the search range (+2.000 s): ..."),),
     "its best offset lies at the edge of the offsets searched"),
    (_stats(), "not connected", (_pair("too few track pairs: only 3 (fewer than 8)"),
                                 _pair("no cross-view track pairs (no matched motion, or Stage 0 kept none)", "v", "w")),
     "too little of its motion could be matched with another video's; try giving a calibration (--calib) or "
     "another camera that sees the same motion"),
    (_stats(), "not connected", (_pair("flat landscape: ..."),), "no pair with another video gave one clear offset"),
    (None, "not connected", (), "no pair with another video gave one clear offset; try a rough offset window"),
])
def test_each_cause_in_one_plain_sentence(stats, why, pairs, says):
    text = plain_reason("v", why, stats, pairs)
    assert text.startswith(says), text
    # no rule names, margins or counts: those are the technical account's
    assert not any(w in text for w in ("margin", "joint vote", "sure", "Stage 0", "track pairs")), text


def test_a_calibrated_run_is_not_told_to_give_a_calibration():
    text = plain_reason("v", "not connected", _stats("calibration", joint=joint_vote({"v": 1.0})))
    assert "--calib" not in text and "--range-s" in text


def test_the_whole_reason_is_the_sentence_then_the_technical_account():
    assert with_plain_reason("a sentence", "the detail; its pairs: ...") == \
        "a sentence. In detail: the detail; its pairs: ..."
