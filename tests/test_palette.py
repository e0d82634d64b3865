"""The recording, the report's figures and its HTML page draw with one palette (vs_inspect.palette)."""
from vs_inspect import palette
from vs_inspect.record import rerun_sink
from vs_inspect.report import figure_style


def test_verdict_colours_are_one_in_recording_and_report():
    assert rerun_sink.ACCEPTED == palette.ACCEPTED
    assert figure_style.ACCEPT == palette.hex_of(palette.ACCEPTED) == "#009E73"
    assert figure_style.REJECT == palette.hex_of(rerun_sink.REJECTED) == "#D55E00"


def test_video_colours_never_mean_a_verdict_and_match_in_both():
    names = [f"cam{i}" for i in range(9)]
    rgb = palette.video_colours(names)
    assert palette.ACCEPTED not in rgb.values() and palette.REJECTED not in rgb.values()
    assert len(set(list(rgb.values())[:len(palette.CAMERA)])) == len(palette.CAMERA)
    as_float = figure_style.video_colors(names)
    assert all(tuple(round(255 * c) for c in as_float[n]) == rgb[n] for n in names)


def test_moving_objects_never_take_a_cameras_colour():
    """Object 0 (and every other) is drawn in a colour no camera has: tracks, masks and lines of
    a moving object are told from the cameras' frustums and labels."""
    cameras = set(palette.video_colours([f"cam{i}" for i in range(12)]).values())
    objects = {palette.instance_colour(i) for i in range(12)}
    assert not cameras & objects
    assert tuple(rerun_sink.instance_colors([0])[0]) == palette.instance_colour(0)
    assert tuple(rerun_sink.instance_colors([-1])[0]) == palette.NEUTRAL


def test_each_colour_means_one_thing():
    """The true Δ is not drawn in the epipolar views' "on the line" yellow, and nothing else is
    drawn in a verdict's colour."""
    meanings = [palette.ACCEPTED, palette.REJECTED, palette.ON_LINE, palette.FAR, palette.TRUTH,
                palette.TRUTH_ON_DARK, palette.SOLVED]
    assert len(set(meanings)) == len(meanings)
    assert rerun_sink.TRUTH != palette.ON_LINE and tuple(rerun_sink.RAMP[-1]) == palette.ON_LINE
    for colours in (palette.CAMERA, palette.INSTANCE, palette.PAIR):
        assert not set(colours) & {palette.ACCEPTED, palette.REJECTED, palette.ON_LINE, palette.SOLVED}


def test_pairs_get_distinct_colours():
    keys = [f"cam{a}__cam{b}" for a in range(5) for b in range(a + 1, 5)]  # 10 pairs
    colours = palette.pair_colours(keys)
    assert len(set(colours.values())) == len(keys) == len(palette.PAIR)


def test_label_text_reads_on_its_background():
    assert palette.text_on((0, 114, 178)) == "white"  # blue
    assert palette.text_on((245, 245, 245)) == "black"  # near-white
    assert palette.tint(palette.REJECTED, 0.1) == (251, 239, 230)
