"""Why a video has no offset, in the user's terms: what was missing and what to try, in one
sentence (RunResult.unresolved_headline, what the offsets table prints). The technical account
(vote margins, rule names, counts, every pair's decision) follows that sentence in
RunResult.unresolved (result.json), and the recording holds each step's own record."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..cue_stats import CueStats

CALIB = "giving a calibration (--calib)"
WINDOW = "a rough offset window (--range-s or --around)"
CAMERA = "another camera that sees the same motion"


def _try(*options: str) -> str:
    """"try a, b or c" of the options given (None or "" left out)."""
    opts = [o for o in options if o]
    if not opts:
        return ""
    return "; try " + (opts[0] if len(opts) == 1 else ", ".join(opts[:-1]) + " or " + opts[-1])


def plain_reason(video: str, why: str, stats: CueStats | None, pairs: Sequence[Any] = ()) -> str:
    """One sentence on why `video` has no offset and what the user can try.

    why: the technical reason (Stage 0's for a video it left out, else Stage 1 and 2's);
    stats: Stage 0's record (None: the run started from a cue bundle); pairs: the run's
    PairLandscapes (their decisions tell a flat landscape from a minimum at the range's edge)."""
    calibrated = stats is None or stats.camera_source.startswith("calibration")
    calib = None if calibrated else CALIB
    dropped = (stats.dropped if stats is not None else {}).get(video)
    note = stats.videos[video].note if stats is not None and video in stats.videos else None
    if dropped is not None and dropped.startswith(("could not be opened", "could not be read")):
        return "the video could not be read; check that the file opens in a video player"
    if dropped is not None and dropped.startswith("the only readable video"):
        return "no other video could be read, so there is nothing to synchronize it with"
    if note is not None:
        return ("nothing moving was found in it to follow; it needs people or objects that move in view "
                "of another camera too")
    if dropped is not None and stats.people is not None and stats.people.kept:
        return _people_reason(video, dropped)
    if dropped is not None:
        if calibrated:
            return ("the calibration gives no usable camera for it; check that the calibration names this "
                    "video and fits its image size")
        return ("its camera could not be placed from the background it shares with the other videos"
                + _try(CALIB, "a video that shows more of that background"))
    if "sightings of camera carriers in a chain" in why:
        return ("its offset would rest on a chain of sightings of people carrying cameras, whose small errors "
                "add up" + _try("another camera that sees the same motion as it and the reference"))
    refusal = stats.refusal_headline(video) if stats is not None else None
    if refusal is not None and "repeated motion" in refusal:
        return "the motion it sees repeats, so more than one offset fits" + _try(WINDOW, CAMERA)
    if refusal is not None:
        return "its offset could not be confirmed by a third camera" + _try(calib, WINDOW, CAMERA)
    if why.startswith("the reference, but no accepted pair"):
        return ("it is the reference, but no other video could be timed against it"
                + _try("another reference (--reference)", CAMERA))
    if why.startswith("its accepted pairs contradict"):
        return "its pairs with the other videos give offsets that disagree" + _try(WINDOW, calib)
    if why.startswith("connected to the reference only through"):
        return ("it is linked to the reference only through videos whose offsets disagree"
                + _try("another camera that sees the same motion as it and the reference"))
    mine = [p.decision.reason for p in pairs if video in (p.a, p.b)]
    if any(r.startswith("best minimum at the edge of the search range") for r in mine):
        return ("its best offset lies at the edge of the offsets searched"
                + _try("a larger --range-s", "videos that overlap more in time"))
    if mine and all("track pairs" in r for r in mine):
        return "too little of its motion could be matched with another video's" + _try(calib, CAMERA)
    return "no pair with another video gave one clear offset" + _try(calib, WINDOW, CAMERA)


def _people_reason(video: str, dropped: str) -> str:
    """The plain sentence of a video the people in view gave no camera (dropped: why, its pairs'
    reasons included)."""
    if "moving camera" in dropped:
        return ("its camera moves, and the people in view time static cameras only"
                + _try(CALIB, "--camera-motion NAME=static if it does not move"))
    if "no people found" in dropped or f"no person followed in {video}" in dropped:  # not its partner's
        return "no person was followed in it, and the background gave no camera" + _try(CALIB, CAMERA)
    if "uncertain shift" in dropped or "flat landscape" in dropped:
        return ("the people it shares with the other videos move too slowly to time it within a frame"
                + _try(CALIB, CAMERA))
    return "the people it shares with the other videos gave no clear time shift" + _try(CALIB, CAMERA)


def with_plain_reason(plain: str, why: str) -> str:
    """result.json's whole reason: the plain sentence, then the technical account."""
    return f"{plain}. In detail: {why}"
