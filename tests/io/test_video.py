"""Video I/O on real files: H.264 written by VideoWriter, decoded back by PyAV (and rerun)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vs_inspect.errors import InputError
from vs_inspect.io.video import VideoWriter, iter_frames, open_video, read_frames

W, H = 160, 96


def frame_image(k: int, w: int = W, h: int = H) -> np.ndarray:
    """A frame that says which frame it is: a flat colour per frame and a moving bright square."""
    img = np.zeros((h, w, 3), np.uint8)
    img[:] = ((k * 37) % 200 + 20, (k * 11) % 200 + 20, 90)
    x = 5 + (k * 3) % (w - 30)
    img[30:55, x:x + 25] = 255
    return img


def write_clip(path, times_s=None, n=40, fps=25.0, w=W, h=H):
    with VideoWriter(path, w, h, fps) as vw:
        for k in range(n if times_s is None else len(times_s)):
            vw.write(frame_image(k, w, h), None if times_s is None else times_s[k])
    return path


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    d = tmp_path_factory.mktemp("clips")
    rng = np.random.default_rng(3)
    vfr = np.concatenate([[0.0], np.cumsum(rng.uniform(0.02, 0.07, 34))])  # phone-like jitter
    return {
        "cfr": write_clip(d / "cfr.mp4", n=40, fps=25.0),
        "vfr": write_clip(d / "vfr.mp4", times_s=vfr),
        "vfr_times": vfr,
        "dir": d,
    }


def test_constant_rate_roundtrip(clips):
    src = open_video(clips["cfr"])
    info = src.info
    assert (info.name, info.width, info.height, info.num_frames) == ("cfr", W, H, 40)
    assert info.fps == pytest.approx(25.0)
    np.testing.assert_allclose(info.timestamps_s, np.arange(40) / 25.0, atol=1e-3)
    frames = list(iter_frames(src))
    assert [k for k, _ in frames] == list(range(40))
    for k, img in frames:
        assert img.shape == (H, W, 3) and img.dtype == np.uint8
        # lossy but close: mean abs error of a few grey levels
        assert np.abs(img.astype(int) - frame_image(k)).mean() < 6.0
    # each decoded frame is closer to its own source image than to its neighbours'
    for k in (1, 20, 38):
        errs = [np.abs(frames[k][1].astype(int) - frame_image(j)).mean() for j in (k - 1, k, k + 1)]
        assert int(np.argmin(errs)) == 1


def test_variable_rate_timestamps(clips):
    src = open_video(clips["vfr"])
    t = clips["vfr_times"]
    assert src.info.num_frames == len(t)
    assert src.info.fps is None  # spacing varies by far more than 5 %
    assert np.abs(src.info.timestamps_s - (t - t[0])).max() < 1e-3


def test_step_downscale_and_read_by_index(clips):
    src = open_video(clips["cfr"])
    full = dict(iter_frames(src))
    stepped = list(iter_frames(src, step=7, max_side=80))
    assert [k for k, _ in stepped] == list(range(0, 40, 7))
    assert stepped[0][1].shape == (48, 80, 3)
    wanted = [33, 0, 17, 17, 39, 2]
    got = read_frames(src, wanted)
    for i, img in zip(wanted, got):
        np.testing.assert_array_equal(img, full[i])  # exact: same decoder, same frame
    with pytest.raises(IndexError):
        read_frames(src, [40])
    src_v = open_video(clips["vfr"])
    full_v = dict(iter_frames(src_v))
    for i, img in zip([30, 4], read_frames(src_v, [30, 4])):
        np.testing.assert_array_equal(img, full_v[i])


def test_odd_size_is_padded_to_even(tmp_path):
    p = write_clip(tmp_path / "odd.mp4", n=5, w=81, h=47)
    info = open_video(p).info
    assert (info.width, info.height) == (82, 48)


def test_writer_is_atomic(tmp_path):
    target = tmp_path / "never.mp4"
    with pytest.raises(RuntimeError):
        with VideoWriter(target, W, H, 10) as vw:
            vw.write(frame_image(0))
            raise RuntimeError("boom")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary file left behind
    with pytest.raises(ValueError, match="increase"):
        with VideoWriter(tmp_path / "x.mp4", W, H, 10) as vw:
            vw.write(frame_image(0), 0.5)
            vw.write(frame_image(1), 0.5)
    assert list(tmp_path.iterdir()) == []


def test_bad_files_give_input_error(clips, tmp_path):
    data = clips["cfr"].read_bytes()
    cases = {
        "cut_end.mp4": data[: len(data) // 2],
        "cut_start.mp4": data[len(data) // 3:],
        "garbage.mp4": np.random.default_rng(0).bytes(4000),
        "empty.mp4": b"",
    }
    for name, blob in cases.items():
        (tmp_path / name).write_bytes(blob)
        with pytest.raises(InputError, match=name):
            open_video(tmp_path / name)
    with pytest.raises(InputError, match="no such file"):
        open_video(tmp_path / "missing.mp4")
    # a stream damaged in the middle: found at open or at the latest while decoding
    bad = bytearray(data)
    bad[len(data) // 3: len(data) // 3 + 3000] = bytes(3000)
    (tmp_path / "mid.mp4").write_bytes(bytes(bad))
    with pytest.raises(InputError, match="mid.mp4"):
        list(iter_frames(open_video(tmp_path / "mid.mp4")))


def test_truncated_faststart_mp4(tmp_path):
    import av
    p = tmp_path / "fast.mp4"
    with av.open(str(p), "w", format="mp4", options={"movflags": "faststart"}) as c:
        s = c.add_stream("libx264", rate=25)
        s.width, s.height, s.pix_fmt = W, H, "yuv420p"
        rng = np.random.default_rng(1)
        for _ in range(30):
            f = av.VideoFrame.from_ndarray(rng.integers(0, 255, (H, W, 3), dtype=np.uint8), format="bgr24")
            for pk in s.encode(f):
                c.mux(pk)
        for pk in s.encode(None):
            c.mux(pk)
    assert open_video(p).info.num_frames == 30
    data = p.read_bytes()
    (tmp_path / "fast_cut.mp4").write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(InputError, match="fast_cut.mp4"):
        open_video(tmp_path / "fast_cut.mp4")


def test_image_folder(tmp_path):
    d = tmp_path / "shots"
    d.mkdir()
    for k in range(12):  # natural order: 2 before 10
        cv2.imwrite(str(d / f"img_{k}.png"), frame_image(k))
    with pytest.raises(InputError, match="--fps"):
        open_video(d)
    src = open_video(d, fps=12.0)
    assert (src.info.name, src.info.num_frames, src.info.fps) == ("shots", 12, 12.0)
    np.testing.assert_allclose(src.info.timestamps_s, np.arange(12) / 12.0)
    frames = dict(iter_frames(src))
    np.testing.assert_array_equal(frames[10], frame_image(10))  # PNG is lossless
    np.testing.assert_array_equal(read_frames(src, [10])[0], frame_image(10))
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no images"):
        open_video(tmp_path / "empty", fps=5)


def test_rerun_asset_video_accepts_writer_output(clips):
    rr = pytest.importorskip("rerun")
    for key in ("cfr", "vfr"):
        asset = rr.AssetVideo(path=clips[key])
        ts_ns = np.asarray(asset.read_frame_timestamps_nanos())
        info = open_video(clips[key]).info
        assert len(ts_ns) == info.num_frames
        np.testing.assert_allclose((ts_ns - ts_ns[0]) / 1e9, info.timestamps_s, atol=1e-3)


def test_real_caliscope_videos(shared_data):
    d = shared_data / "caliscope_post_optimization" / "calibration" / "extrinsic"
    src = open_video(d / "cam_0.mp4")
    assert (src.info.width, src.info.height, src.info.num_frames) == (1280, 720, 57)
    assert src.info.fps == pytest.approx(6.0, rel=0.05)
    img = read_frames(src, [56], max_side=640)[0]
    assert img.shape == (360, 640, 3)


@pytest.mark.parametrize("ext,codec", [("avi", "mpeg4"), ("mkv", "libx264"), ("webm", "libvpx-vp9"),
                                       ("mov", "mjpeg")])
def test_other_containers(tmp_path, ext, codec):
    import av
    if codec not in av.codecs_available:
        pytest.skip(f"{codec} encoder not in this PyAV build")
    p = tmp_path / f"clip.{ext}"
    with av.open(str(p), "w") as c:
        s = c.add_stream(codec, rate=12)
        s.width, s.height = 64, 48
        s.pix_fmt = "yuvj420p" if codec == "mjpeg" else "yuv420p"
        for k in range(15):
            f = av.VideoFrame.from_ndarray(frame_image(k, 64, 48), format="bgr24")
            for pk in s.encode(f):
                c.mux(pk)
        for pk in s.encode(None):
            c.mux(pk)
    src = open_video(p)
    assert (src.info.num_frames, src.info.width, src.info.height) == (15, 64, 48)
    assert src.info.fps == pytest.approx(12.0)
    np.testing.assert_allclose(src.info.timestamps_s, np.arange(15) / 12.0, atol=1e-3)
    frames = dict(iter_frames(src))
    assert sorted(frames) == list(range(15))
    np.testing.assert_array_equal(read_frames(src, [11])[0], frames[11])


@pytest.mark.timeout(60)
def test_read_frames_far_from_keyframe(tmp_path):
    """A target far after its keyframe (long GOP) is reached by decoding on, not by re-seeking."""
    p = write_clip(tmp_path / "long.mp4", n=130, fps=30.0)
    src = open_video(p)
    assert src.info.num_frames == 130
    full = dict(iter_frames(src))
    wanted = [120, 3, 64, 65, 129]
    for i, img in zip(wanted, read_frames(src, wanted)):
        np.testing.assert_array_equal(img, full[i])
