"""One set of colours for the recording, the report's figures and its HTML page.

Each colour has one meaning everywhere, from the Okabe-Ito set (safe for colour-blind readers)
where it has room:

- ACCEPTED (bluish green) and REJECTED (vermillion) mean only a pair's or a check's verdict;
- ON_LINE (yellow) and FAR (blue) only how close an epipolar view's point is to its line;
- TRUTH marks the true offset: black on paper, white in the viewer (its background is dark);
- SOLVED (reddish purple) marks what the global solve (or an --around window) says;
- CAMERA gives each video one colour (its frustum, its bar, its node, its frame), INSTANCE each
  moving object (its tracks, mask and lines), PAIR each pair of videos (its landscape curve).
  CAMERA and INSTANCE share no colour (they are drawn together), and none of the three is a
  colour of the meanings above, so a moving object never looks like a camera and a curve never
  looks like a verdict.
"""
from __future__ import annotations

RGB = tuple[int, int, int]  # 0-255

ACCEPTED: RGB = (0, 158, 115)  # bluish green
REJECTED: RGB = (213, 94, 0)  # vermillion
ON_LINE: RGB = (253, 234, 69)  # yellow, bright on the viewer's black
FAR: RGB = (70, 90, 210)  # blue, readable on the viewer's black
TRUTH: RGB = (0, 0, 0)  # on paper
TRUTH_ON_DARK: RGB = (255, 255, 255)  # in the viewer
SOLVED: RGB = (204, 121, 167)  # reddish purple
NEUTRAL: RGB = (150, 150, 150)  # unknown, no data
OTHER_MINIMA: RGB = (190, 190, 190)  # a landscape's minima other than the chosen one
CAMERA: tuple[RGB, ...] = ((0, 114, 178), (136, 102, 204), (86, 180, 233), (90, 120, 150),
                           (150, 225, 245), (60, 60, 200))  # neighbours in a run differ most
INSTANCE: tuple[RGB, ...] = ((255, 170, 187), (200, 200, 200), (255, 120, 200), (245, 245, 245),
                             (210, 170, 255), (120, 130, 140))
PAIR: tuple[RGB, ...] = ((0, 114, 178), (230, 159, 0), (86, 180, 233), (136, 102, 204),
                         (153, 153, 51), (255, 150, 190), (120, 120, 120), (166, 118, 29),
                         (150, 225, 245), (170, 68, 153))

# The words the report's captions use for the colours it draws (kept beside the colours).
WORDS = {ACCEPTED: "green", REJECTED: "vermillion", TRUTH: "black", SOLVED: "purple"}


def category(i: int, colours: tuple[RGB, ...] = CAMERA) -> RGB:
    """The i-th colour of a set (CAMERA by default), cycling."""
    return colours[i % len(colours)]


def video_colours(names: list[str]) -> dict[str, RGB]:
    """One stable colour per video (CAMERA), by its place in the run's order."""
    return {n: category(i, CAMERA) for i, n in enumerate(names)}


def instance_colour(instance: int) -> RGB:
    """The colour of moving object `instance` (0, 1, ...): INSTANCE, cycling; NEUTRAL for -1."""
    return NEUTRAL if instance < 0 else INSTANCE[instance % len(INSTANCE)]


def pair_colours(keys: list[str]) -> dict[str, RGB]:
    """One colour per pair ("a__b"), by its place in the given order (PAIR, cycling)."""
    return {k: category(i, PAIR) for i, k in enumerate(keys)}


def hex_of(rgb: RGB) -> str:
    return "#{:02X}{:02X}{:02X}".format(*rgb)


def mpl(rgb: RGB) -> tuple[float, float, float]:
    """rgb as matplotlib's floats in [0, 1]."""
    return tuple(c / 255 for c in rgb)  # type: ignore[return-value]


def tint(rgb: RGB, share: float) -> RGB:
    """rgb mixed with white, keeping `share` of the colour (a light background of the same hue)."""
    return tuple(round(255 - share * (255 - c)) for c in rgb)  # type: ignore[return-value]


def text_on(rgb: RGB) -> str:
    """'black' or 'white', whichever reads on rgb (relative luminance, sRGB weights)."""
    r, g, b = rgb
    return "black" if 0.2126 * r + 0.7152 * g + 0.0722 * b > 140 else "white"
