"""The recording's guide ("how to read this recording", the first panel): a text template
filled with what the run logged.

Entity: guide (io/recording_paths.py).
"""

from __future__ import annotations

from string import Template

import rerun as rr

from ..analysis.display_names import legend_lines
from ..io.recording_paths import GUIDE
from .blueprint import MAX_PAIR_CONTAINERS
from .context import RecordingContext

MAX_NOTES = 30  # the stages' last notes listed at the guide's end

OPENING_WITHOUT_PAIRS = """**No pair offset was searched in this run**, so there is no `offset_ms` timeline: the
viewer opens on **`frame`** (each video by its own frame index), and **offsets** (left) says why
each video has no offset; **decision log** and the notes at the end of this guide say what each
stage decided. The rest of this guide describes a run with pairs."""

OPENING_WITH_PAIRS = Template("""The viewer opens on the **`offset_ms`** timeline: the candidate pair offset Δ_ab in milliseconds
over the whole search range${range}. Δ_ab = offset_s[b] − offset_s[a]: video b started Δ_ab later
than a. `vs-inspect view FILE` puts the time cursor at the chosen Δ of the pair in front (`rerun
FILE` opens at the start of the range). Move the cursor (drag it, or type a value in the time
field) to sweep Δ.""")

RANGE = Template(" (${lo} s to ${hi} s)")

CAPPED = Template(" Only the ${shown} most informative of the ${pairs} pairs have a container (rejected "
                  "pairs with the most track pairs first, then accepted pairs from the least clear "
                  "minimum up); every pair is in the **pairs** table and in **all landscapes**; to see "
                  "another pair, add a view with origin `pairs/<a>__<b>`.")

NAMES_LEGEND = Template("\n\nPanel titles, legends and the pair graph draw the videos by short names: ${legend}.")

NOTES = Template("\n## Notes from the stages\n\n${notes}\n")

GUIDE_TEXT = Template("""# How to read this recording

${opening}

**Middle column: one tab per pair a→b, failed pairs first.** ✗ marks a rejected pair, ✓ an accepted
one.${capped}

- *landscape*: the energy E(Δ) of the pair, low where the epipolar constraint holds. The green
  diamond is the chosen Δ (a vermillion cross: a rejected pair's best), grey circles the
  significant minima, a white plus the true Δ when known. A rejected pair usually shows no clear single
  minimum, or its minimum sits at the edge of the search range. A pair timed by the person carrying
  a moving camera seen in the other video (its decision says "sightings of a camera's carrier")
  shows 1 − the share of heads on that camera's centre instead, 0 at the peak; it has no epipolar view. Its
  diamond is the peak fitted again with one constant shift between the heads and the camera
  (the decision gives the shift), so it may sit a little beside the curve's lowest point.
- *epipolar*: one frame of a with the epipolar lines of b's matched points at the cursor's Δ
  (lines in the colour of their moving instance). Points are a's matched points: **yellow** when
  their line passes through them, **blue** when far (scaled to the median distance of this
  pair). At the right Δ the lines go through the points; at a wrong one they miss.
- *decision*: the verdict, its reason and the numbers behind it.

**Left column**: this guide; **pairs** (verdict, chosen and true Δ and reason of every pair);
**offsets** (one per video, with the truth and the error when known); **loop closure** (Δ_ab + Δ_bc
− Δ_ac per triangle of pairs: large residuals point at wrong pairs); the **decision log** (one line
per pair at its chosen Δ). Below: **all landscapes** (every pair's E(Δ), named a→b), the **pair
graph** (videos with their offsets; a node on each evaluated pair's edge, ✓ with Δ or ✗) and the
**IRLS solve** (|residual| and weight per accepted pair, one group of bars per iteration, in the
colours of the pairs' landscapes; the same numbers are on the `iteration` timeline under `sync/solve`).

**Right column**: the videos whose frames the recording holds, and the 3D world. On `offset_ms`
each video shows one still frame with its moving-region mask and tracks. Switch the timeline to **`time`** (seconds after
synchronization) to play the videos together at the solved offsets, or **`frame`** for each
video's own frame index. In 3D: the camera frustums, each labelled with its video's name, a
moving camera's path, and the tracks of accepted pairs triangulated at the solved offsets.

**Colours** (the report's too): green means only *accepted* and vermillion only *rejected* (a
landscape's chosen Δ: green diamond, or vermillion cross for a rejected pair's best); each pair's
curve has a colour of its own; white marks the true Δ (a plus); purple the --around window and
Stage 0's joint vote; yellow a point on its epipolar line and blue one far from it. Each camera has
one colour (its frustum, label and graph node) and each moving object another (its tracks, mask
and lines), never a camera's; the static background of a mask is transparent.

**Video panels empty?** Videos embedded as H.264/AV1 files are decoded by the viewer: the native
viewer runs the `ffmpeg` executable for H.264, which must be on PATH (else the panels say "Failed
to decode: Couldn't find an installation of the FFmpeg executable"); the web viewer
(`rerun --web-viewer FILE.rrd`) decodes in the browser.

Videos in this recording: ${videos}.${names_legend}
""")


def guide_markdown(ctx: RecordingContext, names: list[str], pairs_logged: list[str]) -> str:
    """The guide for the videos `names` and what ctx holds (pairs_logged counts the pairs when
    Stage 2 has not reported)."""
    r = ctx.result
    n_pairs = len(r.pairs) if r is not None else len(pairs_logged)
    shown = min(n_pairs, MAX_PAIR_CONTAINERS)
    lo, hi = ctx.offset_ms_min, ctx.offset_ms_max
    if lo is None:
        opening = OPENING_WITHOUT_PAIRS
    else:
        rng = RANGE.substitute(lo=f"{lo / 1000:+.3f}", hi=f"{hi / 1000:+.3f}") if hi is not None else ""
        opening = OPENING_WITH_PAIRS.substitute(range=rng)
    legend = legend_lines(ctx.display_names())
    md = GUIDE_TEXT.substitute(
        opening=opening,
        capped=CAPPED.substitute(shown=shown, pairs=n_pairs) if n_pairs > shown else "",
        videos=", ".join(names) or "none",
        names_legend=NAMES_LEGEND.substitute(legend="; ".join(
            "**{}** = {}".format(*line.split(" = ", 1)) for line in legend)) if legend else "")
    if ctx.notes:
        md += NOTES.substitute(notes="\n".join(f"- {n}" for n in ctx.notes[-MAX_NOTES:]))
    return md


def log_guide(ctx: RecordingContext, names: list[str], pairs_logged: list[str]) -> None:
    ctx.rec.log(GUIDE, rr.TextDocument(guide_markdown(ctx, names, pairs_logged),
                                       media_type=rr.MediaType.MARKDOWN), static=True)
