"""Short names to draw videos by, where their file names do not fit (figure titles, axis labels,
graph nodes, the viewer's panel titles): `blenderbox_cam06_13_282_0` is drawn as `cam06`.

Names are cut only at separators (_ - . space): the parts every name shares at the start or at
the end are dropped, and when the rest is still long, the fewest leading (or trailing) parts that
tell the videos apart are kept. Names that are short already are drawn as they are. The full
names stay in tables and in a legend (legend_lines).
"""

from __future__ import annotations

import re

MAX_CHARS = 10  # a name at most this long is drawn whole
_SPLIT = re.compile(r"([_\-. ]+)")


def _parts(name: str) -> list[str]:
    """name as alternating words and separators, starting and ending with a word (maybe empty)."""
    return _SPLIT.split(name)


def _join(words: list[str], seps: list[str]) -> str:
    out = words[0]
    for s, w in zip(seps, words[1:]):
        out += s + w
    return out


def display_names(names: list[str], max_chars: int = MAX_CHARS) -> dict[str, str]:
    """name -> a short, unique name to draw it by (the name itself when every name is short).

    Deterministic, and the same for the recording and the report of one run (computed from the
    run's video names alone)."""
    names = list(dict.fromkeys(names))
    if len(names) < 1 or all(len(n) <= max_chars for n in names):
        return {n: n for n in names}
    split = [_parts(n) for n in names]
    words = [p[0::2] for p in split]
    seps = [p[1::2] for p in split]
    if len(names) == 1:
        return {names[0]: names[0]}
    # words shared by all at the start and at the end (each name keeps at least one word)
    shortest = min(len(w) for w in words)
    lead = 0
    while lead < shortest - 1 and len({w[lead] for w in words}) == 1 and len({s[lead] for s in seps}) == 1:
        lead += 1
    trail = 0
    while (trail < shortest - 1 - lead and len({w[-1 - trail] for w in words}) == 1
           and len({s[-1 - trail] for s in seps}) == 1):
        trail += 1
    def core_at(lead: int) -> tuple[list[list[str]], list[list[str]], list[str]]:
        cw = [w[lead:len(w) - trail] for w in words]
        cs = [s[lead:len(s) - trail] for s in seps]
        return cw, cs, [_join(w, s) for w, s in zip(cw, cs)]

    core_words, core_seps, core = core_at(lead)
    # numbers alone say little ("03"): keep shared words before them while the names stay short
    while lead > 0 and not any(ch.isalpha() for c in core for ch in c):
        wider = core_at(lead - 1)
        if max(map(len, wider[2])) > max_chars:
            break
        lead -= 1
        core_words, core_seps, core = wider
    if len(set(core)) == len(core) and all(len(c) <= max_chars for c in core):
        return dict(zip(names, core))
    # the fewest leading words that tell every name apart (else trailing ones, if shorter)
    best = core
    longest = max(len(w) for w in core_words)
    heads = next((h for k in range(1, longest + 1)
                  if len(set(h := [_join(w[:k], s[:k - 1]) for w, s in zip(core_words, core_seps)])) == len(h)),
                 core)
    tails = next((t for k in range(1, longest + 1)
                  if len(set(t := [_join(w[-k:], s[len(s) - k + 1:] if k > 1 else []) for w, s in
                                   zip(core_words, core_seps)])) == len(t)), core)
    if max(map(len, heads)) <= max_chars:
        best = heads
    elif max(map(len, tails)) < max(map(len, heads)):
        best = tails
    else:
        best = heads
    if len(set(best)) != len(best) or any(not b for b in best):
        return {n: n for n in names}
    return dict(zip(names, best))


def legend_lines(short: dict[str, str]) -> list[str]:
    """'cam06 = blenderbox_cam06_13_282_0' for each shortened name (none when nothing was cut)."""
    return [f"{s} = {n}" for n, s in short.items() if s != n]
