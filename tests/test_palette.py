"""The recording and the report draw with one palette (vs_inspect.palette)."""
from vs_inspect import palette
from vs_inspect.record import rerun_sink
from vs_inspect.report import figures


def test_verdict_colours_are_one_in_recording_and_report():
    assert rerun_sink.ACCEPTED == palette.ACCEPTED
    assert figures.ACCEPT == palette.hex_of(palette.ACCEPTED) == "#009E73"
    assert figures.REJECT == palette.hex_of(rerun_sink.REJECTED) == "#D55E00"


def test_video_colours_never_mean_a_verdict_and_match_in_both():
    names = [f"cam{i}" for i in range(9)]
    rgb = palette.video_colours(names)
    assert palette.ACCEPTED not in rgb.values() and palette.REJECTED not in rgb.values()
    assert len(set(list(rgb.values())[:len(palette.CATEGORY)])) == len(palette.CATEGORY)
    as_float = figures.video_colors(names)
    assert all(tuple(round(255 * c) for c in as_float[n]) == rgb[n] for n in names)


def test_label_text_reads_on_its_background():
    assert palette.text_on((0, 114, 178)) == "white"  # blue
    assert palette.text_on((245, 245, 245)) == "black"  # near-white
    assert palette.tint(palette.REJECTED, 0.1) == (251, 239, 230)
