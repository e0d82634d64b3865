"""Cue bundle v1: round trip, and one clear message + exit code 2 for each malformed case."""

import json
import shutil

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.errors import BundleError
from vs_inspect.io.bundle import read_bundle, write_bundle
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene


@pytest.fixture(scope="module")
def good_bundle(tmp_path_factory):
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=1, variable_rate=1, seconds=3.0,
                                          pairs_per_view_pair=60, no_match_pairs=0,
                                          all_wrong_pair=False, seed=2))
    return write_bundle(scene.bundle, tmp_path_factory.mktemp("b") / "bundle"), scene


def test_round_trip_is_exact(good_bundle):
    path, scene = good_bundle
    b = read_bundle(path)
    assert b.names == scene.bundle.names
    for v, w in zip(b.videos, scene.bundle.videos):
        assert np.array_equal(v.timestamps_s, w.timestamps_s) and v.fps == w.fps
    for n in b.names:
        assert np.array_equal(b.tracks[n].xy, scene.bundle.tracks[n].xy, equal_nan=True)
        assert np.array_equal(b.cameras[n].cam_from_world, scene.bundle.cameras[n].cam_from_world)
    assert set(b.pairs) == set(scene.bundle.pairs)
    assert b.gt_offsets_s == scene.bundle.gt_offsets_s
    meta = json.loads((path / "bundle.json").read_text())
    assert meta["format"] == "vs-inspect-cues" and meta["version"] == 1
    vfr = [v for v in meta["videos"] if "timestamps_s" in v]
    assert len(vfr) == 1 and "fps" not in vfr[0]


def test_unchecked_track_pairs_round_trip_in_either_order(good_bundle, tmp_path):
    """Stage 0's mark on track pairs no triangle checked reaches Stage 1 through the files."""
    import dataclasses

    from vs_inspect.types import TrackPairs
    _, scene = good_bundle
    key = sorted(scene.bundle.pairs)[0]
    tp = scene.bundle.pairs[key]
    mark = np.arange(len(tp.index)) % 3 == 0
    pairs = {**scene.bundle.pairs, key: TrackPairs(*key, tp.index, tp.weight, mark)}
    back = read_bundle(write_bundle(dataclasses.replace(scene.bundle, pairs=pairs), tmp_path / "b"))
    assert back.pairs[key].unchecked.dtype == bool and back.pairs[key].unchecked.tolist() == mark.tolist()
    assert back.pair(key[1], key[0]).unchecked.tolist() == mark.tolist()
    assert all(back.pairs[k].unchecked is None for k in back.pairs if k != key)


def test_the_delta_track_pairs_were_chosen_at_round_trips_with_its_sign_in_either_order(good_bundle, tmp_path):
    """Stage 0's Δ_ab at which it kept a pair's track pairs reaches Stage 1 through the files; read
    the other way round it is Δ_ba = -Δ_ab."""
    import dataclasses

    from vs_inspect.types import TrackPairs
    _, scene = good_bundle
    key = sorted(scene.bundle.pairs)[0]
    tp = scene.bundle.pairs[key]
    pairs = {**scene.bundle.pairs, key: TrackPairs(*key, tp.index, tp.weight, None, -0.5167)}
    back = read_bundle(write_bundle(dataclasses.replace(scene.bundle, pairs=pairs), tmp_path / "b"))
    assert back.pairs[key].chosen_at_offset_s == -0.5167
    assert back.pair(key[1], key[0]).chosen_at_offset_s == 0.5167
    assert all(back.pairs[k].chosen_at_offset_s is None for k in back.pairs if k != key)
    with pytest.raises(ValueError, match="chosen_at_offset_s"):
        TrackPairs(*key, tp.index, None, None, float("nan"))


def test_heads_round_trip_and_are_optional(good_bundle, tmp_path):
    """A person detector's heads (the worn-camera sightings' cue) go through the files exactly;
    a bundle without them has none, and one of a wrong length names its file."""
    import dataclasses
    _, scene = good_bundle
    T = scene.bundle.video("cam1").num_frames
    xy = np.full((T, 2), np.nan)
    xy[::3] = np.arange(2 * len(xy[::3])).reshape(-1, 2) + 0.25
    back = read_bundle(write_bundle(dataclasses.replace(scene.bundle, heads={"cam1": xy}), tmp_path / "b"))
    assert list(back.heads) == ["cam1"] and np.array_equal(back.heads["cam1"], xy, equal_nan=True)
    assert read_bundle(good_bundle[0]).heads == {}
    bad = corrupt(tmp_path / "b", tmp_path / "bad", set_npz("heads/cam1.npz", xy=np.zeros((T - 1, 2))))
    with pytest.raises(BundleError, match=r"heads/cam1.npz.*shape"):
        read_bundle(bad)
    with pytest.raises(ValueError, match="heads name unknown video 'zz'"):
        dataclasses.replace(scene.bundle, heads={"zz": xy})


def test_static_points_round_trip_and_are_optional(good_bundle, tmp_path):
    """The static reconstruction of estimated cameras goes through the files (float32 points,
    uint8 colours); a bundle without it has none, and colours that do not match the points are
    refused naming the file."""
    import dataclasses
    _, scene = good_bundle
    points = np.arange(30, dtype=np.float32).reshape(10, 3) / 7
    colors = np.arange(30, dtype=np.uint8).reshape(10, 3)
    back = read_bundle(write_bundle(dataclasses.replace(scene.bundle, static_points=points, static_colors=colors),
                                    tmp_path / "b"))
    assert np.array_equal(back.static_points, points) and np.array_equal(back.static_colors, colors)
    assert read_bundle(good_bundle[0]).static_points is None
    bad = corrupt(tmp_path / "b", tmp_path / "bad", set_npz("static_points.npz", points=points, colors=colors[:4]))
    with pytest.raises(BundleError, match=r"static_points.npz.*4 colours for 10 points"):
        read_bundle(bad)


def test_writer_refuses_to_overwrite_and_leaves_no_partial(good_bundle, tmp_path):
    path, scene = good_bundle
    with pytest.raises(FileExistsError):
        write_bundle(scene.bundle, path)
    assert not [p for p in path.parent.iterdir() if ".partial-" in p.name]


def corrupt(src, dst, edit):
    shutil.copytree(src, dst)
    edit(dst)
    return dst


def set_json(key_path, value):
    def edit(d):
        meta = json.loads((d / "bundle.json").read_text())
        obj = meta
        for k in key_path[:-1]:
            obj = obj[k]
        obj[key_path[-1]] = value
        (d / "bundle.json").write_text(json.dumps(meta))
    return edit


def set_npz(rel, **arrays):
    def edit(d):
        with np.load(d / rel) as z:
            data = {k: z[k] for k in z.files}
        data.update(arrays)
        np.savez(d / rel, **data)
    return edit


K_NAN = np.array([[np.nan, 0, 1], [0, 1, 1], [0, 0, 1]])
K_SINGULAR = np.array([[1.0, 0, 1], [0, 0, 1], [0, 0, 1]])

CASES = {
    "missing camera file": (lambda d: (d / "cameras" / "cam1.npz").unlink(), "cameras/cam1.npz", "missing file"),
    "missing bundle.json": (lambda d: (d / "bundle.json").unlink(), "bundle.json", "missing file"),
    "tracks wrong shape": (set_npz("tracks/cam0.npz", xy=np.zeros((5, 7, 3))), "tracks/cam0.npz", "shape"),
    "tracks wrong frame count": (set_npz("tracks/cam0.npz", xy=np.zeros((5, 7, 2)), instance=np.zeros(5, int)), "tracks/cam0.npz", "frames"),
    "K with NaN": (set_npz("cameras/cam0.npz", K=K_NAN), "cameras/cam0.npz", "NaN"),
    "singular K": (set_npz("cameras/cam0.npz", K=K_SINGULAR), "cameras/cam0.npz", "singular"),
    "pose not a rotation": (set_npz("cameras/cam0.npz", cam_from_world=np.diag([2.0, 1, 1, 1])),
                            "cameras/cam0.npz", "not a rotation"),
    "non-increasing timestamps": (set_json(["videos", 1, "timestamps_s", 3], -1.0), "bundle.json", "strictly increasing"),
    "pair index out of range": (set_npz("pairs/cam0__cam1.npz", index=np.array([[0, 10**6]])),
                                "pairs/cam0__cam1.npz", "out of range"),
    "pair file names unknown video": (lambda d: shutil.copy(d / "pairs" / "cam0__cam1.npz", d / "pairs" / "cam0__zz9.npz"),
                                      "pairs/cam0__zz9.npz", "known videos"),
    "unchecked marks of another length": (set_npz("pairs/cam0__cam1.npz", unchecked=np.zeros(3, bool)),
                                          "pairs/cam0__cam1.npz", "unchecked"),
    "unchecked marks not booleans": (set_npz("pairs/cam0__cam1.npz", unchecked=np.full(60, 2)),
                                     "pairs/cam0__cam1.npz", "booleans"),
    "chosen offset not a number": (set_npz("pairs/cam0__cam1.npz", chosen_at_offset_s=np.float64("nan")),
                                   "pairs/cam0__cam1.npz", "chosen_at_offset_s"),
    "chosen offset not one number": (set_npz("pairs/cam0__cam1.npz", chosen_at_offset_s=np.zeros(2)),
                                     "pairs/cam0__cam1.npz", "chosen_at_offset_s"),
    "empty bundle": (set_json(["videos"], []), "bundle.json", "empty bundle"),
    "wrong format": (set_json(["format"], "something"), "bundle.json", "format"),
    "bad fps": (set_json(["videos", 0, "fps"], -3), "bundle.json", "fps"),
    "corrupt npz": (lambda d: (d / "tracks" / "cam2.npz").write_bytes(b"not a zip"), "tracks/cam2.npz", "readable"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_bundle_gets_one_clear_message_and_exit_2(case, good_bundle, tmp_path, capsys):
    edit, where, what = CASES[case]
    bad = corrupt(good_bundle[0], tmp_path / "bad", edit)
    with pytest.raises(BundleError) as info:
        read_bundle(bad)
    assert where in str(info.value).replace("\\", "/") and what in str(info.value)
    out_dir = tmp_path / "out"
    assert main(["sync", "--bundle", str(bad), "--out", str(out_dir), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and where in err[0] and "Traceback" not in err[0]
    assert not (out_dir / "result.json").exists()


def test_not_a_folder(tmp_path, capsys):
    assert main(["sync", "--bundle", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "nope" in err and ("not a folder" in err or "missing" in err), err


def test_npz_headers_are_read_without_loading_the_arrays(tmp_path):
    from vs_inspect.io.bundle import _npy_headers
    np.savez_compressed(tmp_path / "a.npz", xy=np.zeros((2000, 50, 2), np.float32), n=np.arange(3))
    h = _npy_headers(tmp_path / "a.npz")
    assert h["xy"][0] == (2000, 50, 2) and h["xy"][1] == np.float32
    assert h["n"][0] == (3,)


def test_embedded_bundle_larger_than_the_budget_is_refused(tmp_path, monkeypatch):
    import io
    import zipfile

    from vs_inspect.io.bundle_zip import bundle_from_zip_bytes
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("tracks/a.npz", b"\0" * (3 << 20))  # 3 MB that compresses to a few kB
    monkeypatch.setenv("VS_INSPECT_MEMORY_BUDGET_MB", "2")
    with pytest.raises(BundleError, match="unpacks to 3.0 MB, more than the memory budget"):
        bundle_from_zip_bytes(buf.getvalue(), "r.rrd")
