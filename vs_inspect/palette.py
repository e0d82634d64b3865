"""One set of colours for the recording and the report, from the Okabe-Ito set (safe for
colour-blind readers). Bluish green and vermillion mean only "accepted" and "rejected"; videos,
cameras and moving instances take CATEGORY, which has neither (nor orange, too near vermillion,
nor yellow, the epipolar views' "on the line")."""
from __future__ import annotations

RGB = tuple[int, int, int]  # 0-255

ACCEPTED: RGB = (0, 158, 115)  # bluish green
REJECTED: RGB = (213, 94, 0)  # vermillion
CATEGORY: tuple[RGB, ...] = ((86, 180, 233), (204, 121, 167), (0, 114, 178), (170, 150, 230),
                             (250, 190, 212), (150, 225, 245), (245, 245, 245))


def category(i: int) -> RGB:
    """The i-th category colour, cycling."""
    return CATEGORY[i % len(CATEGORY)]


def video_colours(names: list[str]) -> dict[str, RGB]:
    """One stable colour per video, by its place in the run's order."""
    return {n: category(i) for i, n in enumerate(names)}


def hex_of(rgb: RGB) -> str:
    return "#{:02X}{:02X}{:02X}".format(*rgb)


def tint(rgb: RGB, share: float) -> RGB:
    """rgb mixed with white, keeping `share` of the colour (a light background of the same hue)."""
    return tuple(round(255 - share * (255 - c)) for c in rgb)  # type: ignore[return-value]


def text_on(rgb: RGB) -> str:
    """'black' or 'white', whichever reads on rgb (relative luminance, sRGB weights)."""
    r, g, b = rgb
    return "black" if 0.2126 * r + 0.7152 * g + 0.0722 * b > 140 else "white"
