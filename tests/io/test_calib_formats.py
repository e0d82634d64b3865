"""Calibration formats on real files from each tool's own repository (tests/io/data/README.md):
values and a reprojection check per format (a point every camera sees lands inside every image,
in front of the camera), the same cameras through two readers, round trips through every writer,
and the refusals: XML with a DTD (billion laughs), pickles, sizes that are not a crop or binning."""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np  # noqa: I001
import cv2
import pytest

from vs_inspect.cli import main
from vs_inspect.errors import InputError
from vs_inspect.io.calib import FORMATS, read, read_named, write
from vs_inspect.io.calib.vicon import quat_xyzw_to_matrix
from vs_inspect.io.calibration import fit_to_video, undistort_points

DATA = Path(__file__).parent / "data"


def project(cal, X: np.ndarray, with_dist: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(pixels (N,2), depth (N,)) of world points X (N,3)."""
    R, t = cal.cam_from_world[:3, :3], cal.cam_from_world[:3, 3]
    Xc = X @ R.T + t
    px = cv2.projectPoints(X, cv2.Rodrigues(R)[0], t, cal.K,
                           cal.dist if with_dist else np.zeros(5))[0].reshape(-1, 2)
    return px, Xc[:, 2]


def common_view_point(cals) -> np.ndarray:
    """The point nearest every camera's optical axis (least squares)."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    for c in cals:
        R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
        centre, axis = -R.T @ t, R[2]
        P = np.eye(3) - np.outer(axis, axis)
        A += P
        b += P @ centre
    return np.linalg.solve(A, b)


def assert_rig_sees(cals, size, point=None, margin=0.1):
    """A point all cameras look at projects inside every image (away from the border), in front."""
    X = common_view_point(cals) if point is None else np.asarray(point, float)
    for c in cals:
        px, z = project(c, X[None])
        w, h = size
        assert z[0] > 0.5, f"behind or at the camera: z = {z[0]}"
        assert margin * w < px[0, 0] < (1 - margin) * w and margin * h < px[0, 1] < (1 - margin) * h, px


def test_qualisys_qca_matches_pose2sim_conversion():
    """Pose2Sim's demo Calib.qca.txt and the TOML Pose2Sim converted from it: same K and pose,
    same pixels for points across the capture volume."""
    qca = read(DATA / "pose2sim_Calib.qca.txt")
    toml = read(DATA / "pose2sim_Calib_qualisys.toml")
    assert list(qca) == ["cam_01", "cam_02", "cam_03", "cam_04"]
    c1 = qca["cam_01"][1]
    assert c1.size == (1088, 1920)
    assert c1.K[0, 0] == pytest.approx(107599.671875 / 64)
    assert c1.K[1, 2] == pytest.approx(60680.792969 / 64)
    # camera centre = <transform x y z> in mm, read in metres
    centre = -c1.cam_from_world[:3, :3].T @ c1.cam_from_world[:3, 3]
    np.testing.assert_allclose(centre, [1.4602323709212087, -1.9091590482454608, 1.8965058524092062], atol=1e-12)
    # lens coefficients as QTM writes them (normalized coordinates), k1 k2 p1 p2 k3
    np.testing.assert_allclose(c1.dist, [-0.046183, 0.139983, 0.000608, 0.00069, 0.0])
    rng = np.random.default_rng(3)
    X = rng.uniform([-1.5, -1.5, 0.0], [1.5, 1.5, 2.0], size=(200, 3))
    for (_, a), (_, b) in zip(qca.values(), toml.values()):
        np.testing.assert_allclose(a.K, b.K, atol=1e-6)
        np.testing.assert_allclose(a.cam_from_world, b.cam_from_world, atol=1e-6)
        pa, za = project(a, X, with_dist=False)
        pb, zb = project(b, X, with_dist=False)
        assert np.abs(pa - pb).max() < 1e-4
        assert (za > 0).all()  # the capture volume is in front of every camera
    assert_rig_sees([c for _, c in qca.values()], (1088, 1920))


def test_freemocap_toml_in_millimetres():
    cams = read(DATA / "freemocap_camera_calibration.toml")
    assert [n[0] for n, _ in cams.values()][0].endswith("_Cam1")
    c = [c for _, c in cams.values()]
    assert c[0].size == (720, 1280)
    # translation -2512.7 mm in the file: metres after reading
    np.testing.assert_allclose(c[1].cam_from_world[:3, 3], [-2.512748578975975, -0.6457397803840619, 0.73892329282478])
    baseline = np.linalg.norm(-c[1].cam_from_world[:3, :3].T @ c[1].cam_from_world[:3, 3])
    assert 1.0 < baseline < 5.0
    assert_rig_sees(c, (720, 1280))


def test_easymocap_yml_pair():
    """intri.yml/extri.yml (EasyMocap's layout, from A-NeRF): the same cameras from the folder
    or either file; R_ (Rodrigues) and Rot_ (matrix) agree; the world origin, where the
    subject stands, is in front of every camera and inside its 1920x1080 image."""
    by_dir = read(DATA / "easymocap")
    assert list(by_dir) == ["2", "3", "4", "5", "6", "7"]
    for f in ("intri.yml", "extri.yml"):
        other = read(DATA / "easymocap" / f)
        for k in by_dir:
            np.testing.assert_array_equal(other[k][1].K, by_dir[k][1].K)
    c2 = by_dir["2"][1]
    assert c2.K[0, 0] == pytest.approx(1270.5470221290213)
    R_rod = cv2.Rodrigues(np.array([1.7333808154182149, 0.27177228964133848, -0.21631450334637528]))[0]
    np.testing.assert_allclose(c2.cam_from_world[:3, :3], R_rod, atol=1e-6)
    np.testing.assert_allclose(c2.cam_from_world[:3, 3], [0.13811055048575024, 0.13941702782968118, 5.8653820170920312])
    assert c2.size is None  # EasyMocap stores no image size
    assert_rig_sees([c for _, c in by_dir.values()], (1920, 1080), point=np.zeros(3), margin=0.2)


def _xcp(cams: dict, radial: str = "") -> str:
    """An .xcp in Vicon's layout for OpenCV cameras: quaternion (x y z w) of world -> camera,
    position in mm (the quaternion from scipy, independent of the reader)."""
    from scipy.spatial.transform import Rotation
    rows = ['<?xml version="1.0" encoding="UTF-8" standalone="no" ?>', '<Cameras NAME="" VERSION="1.0">']
    for i, (n, c) in enumerate(cams.items()):
        R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
        q = Rotation.from_matrix(R).as_quat()
        pos = -R.T @ t * 1000
        K = c.K.tolist()
        K = np.array(K)
        f = lambda x: repr(float(x))  # noqa: E731
        rows += [f'<Camera DEVICEID="{2100 + i}" NAME="{n}" USERID="{i + 1}" PIXEL_ASPECT_RATIO="{f(K[0, 0] / K[1, 1])}" '
                 f'SENSOR_SIZE="{c.size[0]} {c.size[1]}" SKEW="0" TYPE="VIDEO"><KeyFrames>',
                 f'<KeyFrame FOCAL_LENGTH="{f(K[0, 0])}" FRAME="0" ORIENTATION="{" ".join(map(repr, map(float, q)))}" '
                 f'POSITION="{" ".join(map(repr, map(float, pos)))}" PRINCIPAL_POINT="{f(K[0, 2])} {f(K[1, 2])}" {radial}/>',
                 '</KeyFrames></Camera>']
    return "\n".join(rows + ["</Cameras>"])


def test_vicon_xcp_pose_units_and_lens(tmp_path, caplog):
    """The Qualisys rig written in Vicon's layout reads back to the same cameras (mm -> m, the
    quaternion's matrix is world -> camera); VICON_RADIAL (pixel units, distorted -> undistorted)
    is converted to OpenCV coefficients that undistort points as Vicon's model does."""
    rig = {n: c for n, (_, c) in read(DATA / "pose2sim_Calib.qca.txt").items()}
    (tmp_path / "rig.xcp").write_text(_xcp(rig))
    got = read(tmp_path / "rig.xcp")
    assert list(got) == ["2100", "2101", "2102", "2103"] and got["2100"][0][1] == "cam_01"
    for (_, g), c in zip(got.values(), rig.values()):
        np.testing.assert_allclose(g.cam_from_world, c.cam_from_world, atol=1e-9)
        np.testing.assert_allclose(g.K[:2, :], c.K[:2, :], atol=1e-9)
    assert_rig_sees([g for _, g in got.values()], (1088, 1920))
    np.testing.assert_allclose(quat_xyzw_to_matrix([0, 0, np.sin(0.25), np.cos(0.25)]),
                               cv2.Rodrigues(np.array([0, 0, 0.5]))[0], atol=1e-12)
    k1 = -2.0e-7  # px^-2: points 1000 px from the centre move by 200 px
    (tmp_path / "lens.xcp").write_text(_xcp({"cam_01": rig["cam_01"]}, f'VICON_RADIAL="{k1!r} 0"'))
    with caplog.at_level(logging.INFO):
        cal = read(tmp_path / "lens.xcp")["2100"][1]
    assert cal.dist.size == 8  # OpenCV's rational model
    c = cal.K[:2, 2]
    xd = np.array([[100.0, 200.0], [1000.0, 1800.0], [600.0, 900.0]])
    r2 = ((xd - c) ** 2).sum(1)
    xu_vicon = c + (xd - c) * (1 + k1 * r2)[:, None]
    assert np.abs(undistort_points(cal, xd) - xu_vicon).max() < 0.05
    assert np.abs(xu_vicon - xd).max() > 5  # the lens does matter


def test_every_writer_round_trips(tmp_path, caplog):
    """Every format gives back the same cameras. Vicon's lens model has no tangential terms: the
    rig is written without them there (dropping them is a warning, tested below)."""
    from dataclasses import replace
    full = read_named(DATA / "pose2sim_Calib.qca.txt")
    radial = {n: replace(c, dist=np.r_[c.dist[:2], 0.0, 0.0, c.dist[4:]]) for n, c in full.items()}
    with caplog.at_level(logging.WARNING):
        write(full, tmp_path / "tangential.xcp")
    assert caplog.text.count("no tangential terms") == 4
    for name, fmt in FORMATS.items():
        rig = radial if name == "vicon" else full
        out = tmp_path / (name + (".qca.txt" if name == "qualisys" else ".xcp" if name == "vicon"
                                  else ".json" if name == "json" else "" if fmt.folder else ".toml"))
        write(rig, out, name)
        back = read_named(out)
        assert list(back) == list(rig), name
        for n in rig:
            np.testing.assert_allclose(back[n].K, rig[n].K, atol=1e-9, err_msg=name)
            np.testing.assert_allclose(back[n].cam_from_world, rig[n].cam_from_world, atol=1e-9, err_msg=name)
            assert back[n].size == rig[n].size or back[n].size is None, name
            if name != "vicon":  # Vicon has no tangential terms: its lens is a fit
                np.testing.assert_allclose(back[n].dist[:4], rig[n].dist[:4], atol=1e-12, err_msg=name)
            else:  # the fitted lens undistorts the image as the original does
                grid = np.stack(np.meshgrid(np.linspace(0, 1087, 9), np.linspace(0, 1919, 9)), -1)
                diff = np.abs(undistort_points(back[n], grid) - undistort_points(rig[n], grid)).max()
                assert diff < 0.15, (n, diff)


def test_calib_convert_colmap_pose2sim_json_within_1e6(tmp_path, capsys):
    """COLMAP -> Pose2Sim TOML -> JSON with the CLI keeps every camera within 1e-6."""
    rig = read_named(DATA / "pose2sim_Calib.qca.txt")
    write(rig, tmp_path / "sparse", "colmap")
    assert main(["calib", "convert", str(tmp_path / "sparse"), str(tmp_path / "Calib.toml")]) == 0
    assert main(["calib", "convert", str(tmp_path / "Calib.toml"), str(tmp_path / "cams.json")]) == 0
    assert "as pose2sim" in capsys.readouterr().out
    colmap, js = read_named(tmp_path / "sparse"), read_named(tmp_path / "cams.json")
    assert list(js) == list(colmap)
    for n in colmap:
        for a, b in ((colmap[n].K, js[n].K), (colmap[n].cam_from_world, js[n].cam_from_world),
                     (colmap[n].dist[:4], js[n].dist[:4])):
            assert np.abs(a - b).max() < 1e-6
        assert js[n].size == colmap[n].size
    # refusals: existing output, unknown output format, a pickle
    assert main(["calib", "convert", str(tmp_path / "Calib.toml"), str(tmp_path / "cams.json")]) == 2
    assert main(["calib", "convert", str(tmp_path / "Calib.toml"), str(tmp_path / "cams.xyz")]) == 2
    assert "--to" in capsys.readouterr().err


def test_pickle_refused_with_how_to_convert(tmp_path):
    import pickle
    p = tmp_path / "calib.dat"
    p.write_bytes(pickle.dumps({"K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}))
    with pytest.raises(InputError, match=r"pickle.*never loaded.*\.json"):
        read(p)  # told by its content
    with pytest.raises(InputError, match=r"pickle.*never loaded.*\.json"):
        read(p.rename(tmp_path / "calib.pickle"))


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
<!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
<!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
<!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
<!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
<!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
<!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
<!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">]>
<calibration><cameras><camera serial="&lol9;"/></cameras></calibration>
"""


def test_xml_with_entities_refused_quickly(tmp_path):
    import tracemalloc
    for name, text in (("bomb.qca.txt", BILLION_LAUGHS),
                       ("ext.xcp", '<?xml version="1.0"?><!DOCTYPE x [<!ENTITY e SYSTEM "file:///etc/passwd">]>'
                                   '<Cameras><Camera NAME="&e;"/></Cameras>')):
        (tmp_path / name).write_text(text)
        tracemalloc.start()
        t0 = time.perf_counter()
        with pytest.raises(InputError, match="DOCTYPE"):
            read(tmp_path / name)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert time.perf_counter() - t0 < 1.0 and peak < 5_000_000
    (tmp_path / "bad.xcp").write_text("<Cameras><Camera")
    with pytest.raises(InputError, match="not valid XML"):
        read(tmp_path / "bad.xcp")


def test_size_mismatch_crop_and_binning(caplog):
    """1080 columns for a 1088-wide calibration (the encoder's padding): accepted, one warning,
    K unchanged; a centred crop of 20 rows moves the principal point by 10; binning by 2 halves
    K; anything else is refused."""
    cal = read_named(DATA / "pose2sim_Calib.qca.txt")["cam_01"]
    with caplog.at_level(logging.WARNING):
        narrow = fit_to_video(cal, 1080, 1920, name="cam_01")
    assert len(caplog.records) == 1 and "8 columns cut at the right" in caplog.text
    np.testing.assert_array_equal(narrow.K, cal.K)
    assert narrow.size == (1080, 1920)
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        short = fit_to_video(cal, 1088, 1900, name="cam_01")
    assert len(caplog.records) == 1 and "20 rows cut evenly" in caplog.text
    assert short.K[1, 2] == pytest.approx(cal.K[1, 2] - 10)
    assert short.K[0, 2] == cal.K[0, 2]
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        binned = fit_to_video(cal, 544, 960, name="cam_01")
    assert len(caplog.records) == 1 and "binned by 2" in caplog.text
    assert binned.K[0, 0] == pytest.approx(cal.K[0, 0] / 2)
    assert binned.K[0, 2] == pytest.approx((cal.K[0, 2] + 0.5) / 2 - 0.5)
    for w, h in ((1000, 1920), (1088, 1800), (1100, 1920), (1920, 1088)):
        with pytest.raises(InputError, match="calibration for other cameras"):
            fit_to_video(cal, w, h, name="cam_01")
