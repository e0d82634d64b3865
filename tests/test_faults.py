"""Fault injection: every bad input, bad option and failing file system gives ONE line
`vs-inspect CMD: error: ...` naming the file or the option, exit 2 (SIGTERM: 143), no traceback,
and leaves exactly the files listed (no hidden .partial files, no stale outputs).

Read-only and full file systems are small tmpfs mounts when the test may mount (root), else a
chmod 0o555 folder (read-only only); skipped with the reason otherwise.
"""

from __future__ import annotations

import io
import json
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.io.bundle import write_bundle
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

REPO = Path(__file__).resolve().parents[1]


# ---- helpers -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def bundle_dir(tmp_path_factory):
    sc = make_cue_scene(CueSceneConfig(cameras=3, moving=1, seconds=4.0, pairs_per_view_pair=100,
                                       max_offset_s=1.0, seed=6))
    return write_bundle(sc.bundle, tmp_path_factory.mktemp("faults") / "bundle")


@pytest.fixture(scope="module")
def run_dir(bundle_dir, tmp_path_factory):
    """A finished sync run (result.json, config.json) of bundle_dir."""
    out = tmp_path_factory.mktemp("faults") / "run"
    assert main(["sync", "--bundle", str(bundle_dir), "--out", str(out), "--no-rrd", "--no-progress"]) == 0
    return out


def tree(folder: Path) -> list[str]:
    """Every file and folder below `folder` (hidden ones included), relative, sorted."""
    folder = Path(folder)
    if not folder.exists():
        return []
    return sorted(str(p.relative_to(folder)) + ("/" if p.is_dir() else "") for p in folder.rglob("*"))


def fails(argv: list[str], capsys, code: int = 2, *needles: str) -> str:
    """Run the CLI; assert the exit code and ONE stderr line with the needles and no traceback."""
    got = main([str(a) for a in argv])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert got == code, err
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith(f"vs-inspect {argv[0]}: error: "), lines[0]
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def sync_argv(bundle: Path, out: Path, *more) -> list:
    return ["sync", "--bundle", bundle, "--out", out, "--no-progress", *more]


def edit_bundle(src: Path, dst: Path, meta_edit=None, arrays: dict | None = None) -> Path:
    """A copy of a bundle with bundle.json edited (meta_edit(meta)) and .npz files replaced."""
    import shutil
    shutil.copytree(src, dst)
    if meta_edit is not None:
        meta = json.loads((dst / "bundle.json").read_text())
        meta_edit(meta)
        (dst / "bundle.json").write_text(json.dumps(meta))
    for rel, new in (arrays or {}).items():
        with np.load(dst / rel) as z:
            data = {k: z[k] for k in z.files}
        data.update(new)
        np.savez(dst / rel, **data)
    return dst


def _can_mount() -> str | None:
    if os.geteuid() != 0:
        return "not root: tmpfs mounts are not permitted"
    if sys.platform != "linux":
        return "tmpfs mounts need Linux"
    return None


@contextmanager
def tmpfs(folder: Path, size: str = "64k"):
    folder.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                       capture_output=True, text=True, check=False)
    if r.returncode != 0:
        pytest.skip(f"mounting a tmpfs is not permitted here ({r.stderr.strip()})")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


@contextmanager
def read_only_folder(folder: Path):
    """A folder no one may write to: a read-only tmpfs as root, chmod 0o555 otherwise."""
    if os.geteuid() == 0:
        with tmpfs(folder):
            (folder / "keep.txt").write_text("earlier content\n")
            r = subprocess.run(["mount", "-o", "remount,ro", str(folder)], capture_output=True, text=True,
                               check=False)
            if r.returncode != 0:
                pytest.skip(f"remounting read-only is not permitted here ({r.stderr.strip()})")
            yield folder
    else:
        folder.mkdir(parents=True)
        (folder / "keep.txt").write_text("earlier content\n")
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(0o755)


# ---- file systems and output paths --------------------------------------------------------------


def test_out_below_a_regular_file(bundle_dir, tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    fails(sync_argv(bundle_dir, tmp_path / "afile" / "out", "--no-rrd"), capsys, 2, "afile", "not a folder")
    assert tree(tmp_path) == ["afile"]


def test_rrd_naming_a_folder_fails_before_any_work(bundle_dir, tmp_path, capsys):
    (tmp_path / "recs").mkdir()
    t0 = time.perf_counter()
    fails(sync_argv(bundle_dir, tmp_path / "out", "--rrd", tmp_path / "recs"), capsys, 2, "--rrd", "is a folder")
    assert time.perf_counter() - t0 < 5
    assert tree(tmp_path) == ["recs/"]


def test_rrd_below_a_regular_file(bundle_dir, tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    fails(sync_argv(bundle_dir, tmp_path / "out", "--rrd", tmp_path / "afile" / "r.rrd"), capsys, 2, "afile")
    assert tree(tmp_path) == ["afile"]


def test_read_only_file_system(bundle_dir, tmp_path, capsys):
    ro = tmp_path / "ro"
    with read_only_folder(ro):
        if os.access(ro, os.W_OK) and os.geteuid() != 0:
            pytest.skip("chmod 0o555 does not stop writes here")
        line = fails(sync_argv(bundle_dir, ro / "out", "--no-rrd"), capsys, 2, str(ro / "out"))
        assert "read-only file system" in line or "Permission denied" in line
        assert tree(ro) == ["keep.txt"]


def test_read_only_file_system_for_the_recording(bundle_dir, tmp_path, capsys):
    ro = tmp_path / "ro"
    with read_only_folder(ro):
        if os.access(ro, os.W_OK) and os.geteuid() != 0:
            pytest.skip("chmod 0o555 does not stop writes here")
        line = fails(sync_argv(bundle_dir, tmp_path / "out", "--rrd", ro / "run.rrd"), capsys, 2, str(ro))
        assert "read-only file system" in line or "Permission denied" in line
        assert tree(ro) == ["keep.txt"]
    assert tree(tmp_path) == ["ro/"]


@pytest.mark.skipif(_can_mount() is not None, reason=str(_can_mount()))
def test_full_file_system(bundle_dir, tmp_path, capsys):
    full = tmp_path / "full"
    with tmpfs(full, "64k"):
        # leave less room than result.json needs (it is about 13 kB for this bundle)
        filler = full / "filler.bin"
        with open(filler, "wb") as f:
            try:
                f.write(b"\0" * (64 * 1024 - 6 * 1024))
            except OSError:
                pass
        fails(sync_argv(bundle_dir, full / "out", "--no-rrd"), capsys, 2, "no space left on device")
        assert tree(full) == ["filler.bin"]  # no half-written result.json, no empty out folder


@pytest.mark.skipif(_can_mount() is not None, reason=str(_can_mount()))
def test_full_file_system_for_the_recording(bundle_dir, tmp_path, capsys):
    full = tmp_path / "full"
    with tmpfs(full, "64k"):
        fails(sync_argv(bundle_dir, tmp_path / "out", "--rrd", full / "run.rrd"), capsys, 2,
              "no space left on device")
        assert tree(full) == []  # no .run.rrd.*.partial left
    assert tree(tmp_path) == ["full/"]  # and no result.json without its recording


def test_export_mosaic_naming_a_folder(run_dir, tmp_path, capsys):
    (tmp_path / "m").mkdir()
    fails(["export", run_dir, "--mosaic", tmp_path / "m"], capsys, 2, "--mosaic", "is a folder")
    assert tree(tmp_path) == ["m/"]


def test_export_refuses_an_existing_mosaic_without_force(run_dir, tmp_path, capsys):
    (tmp_path / "m.mp4").write_text("earlier")
    fails(["export", run_dir, "--mosaic", tmp_path / "m.mp4"], capsys, 2, "--force")
    assert (tmp_path / "m.mp4").read_text() == "earlier"



@pytest.fixture(scope="module")
def clips_run_dir(tmp_path_factory):
    """A result.json over two real noisy clips: its mosaic is far larger than a 16 kB tmpfs."""
    from vs_inspect.io.video import VideoWriter
    d = tmp_path_factory.mktemp("clips")
    rng = np.random.default_rng(0)
    paths = {}
    for name in ("left", "right"):
        paths[name] = d / f"{name}.mp4"
        with VideoWriter(paths[name], 160, 96, 10.0) as vw:
            for _ in range(20):
                vw.write(rng.integers(0, 256, (96, 160, 3), dtype=np.uint8))
    result = {"reference": "left", "offsets_s": {"left": 0.0, "right": 0.3}, "unresolved": {},
              "input": {"videos": {n: str(p) for n, p in paths.items()}}}
    (d / "result.json").write_text(json.dumps(result))
    return d


def test_export_mosaic_on_a_read_only_file_system(clips_run_dir, tmp_path, capsys):
    ro = tmp_path / "ro"
    with read_only_folder(ro):
        if os.access(ro, os.W_OK) and os.geteuid() != 0:
            pytest.skip("chmod 0o555 does not stop writes here")
        line = fails(["export", clips_run_dir, "--mosaic", ro / "m.mp4", "--no-progress"], capsys, 2,
                     str(ro))
        assert "read-only file system" in line or "Permission denied" in line
        assert tree(ro) == ["keep.txt"]


@pytest.mark.skipif(_can_mount() is not None, reason=str(_can_mount()))
def test_export_mosaic_on_a_full_file_system(clips_run_dir, tmp_path, capsys):
    full = tmp_path / "full"
    with tmpfs(full, "16k"):
        fails(["export", clips_run_dir, "--mosaic", full / "m.mp4", "--no-progress"], capsys, 2,
              "no space left on device")
        assert tree(full) == []  # no hidden .part.mp4 left


# ---- overwrite guard, names of outputs, file modes --------------------------------------------


def test_sync_refuses_an_earlier_run_unless_force(bundle_dir, run_dir, tmp_path, capsys):
    import shutil
    out = tmp_path / "run"
    shutil.copytree(run_dir, out)
    (out / "cues").mkdir()  # as an earlier run from videos leaves it
    (out / "cues" / "bundle.json").write_text("{}")
    before = (out / "result.json").read_bytes()
    fails(sync_argv(bundle_dir, out, "--no-rrd"), capsys, 2, str(out), "--force")
    assert tree(out) == ["cameras.json", "config.json", "cues/", "cues/bundle.json", "result.json"]
    assert (out / "result.json").read_bytes() == before
    assert main([str(a) for a in sync_argv(bundle_dir, out, "--no-rrd", "--force")]) == 0
    assert tree(out) == ["cameras.json", "config.json", "result.json"]  # the earlier run's cues are not this run's
    # --overwrite is the old name of --force (cues, synth-cues, import-visualsync)
    assert main([str(a) for a in sync_argv(bundle_dir, out, "--no-rrd", "--overwrite")]) == 0


def test_default_recordings_of_a_out_and_b_out_differ(bundle_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("VS_INSPECT_RECORDINGS", str(tmp_path / "recs"))
    for d in ("a", "b"):
        assert main([str(x) for x in sync_argv(bundle_dir, tmp_path / d / "out", "--rrd-minimal")]) == 0
    names = tree(tmp_path / "recs")
    assert len(names) == 2 and all(n.startswith("out-") and n.endswith(".rrd") for n in names)


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077])
def test_result_json_follows_the_umask(bundle_dir, tmp_path, umask):
    old = os.umask(umask)
    try:
        assert main([str(a) for a in sync_argv(bundle_dir, tmp_path / "out", "--no-rrd")]) == 0
    finally:
        os.umask(old)
    for name in ("result.json", "config.json"):
        assert stat.S_IMODE((tmp_path / "out" / name).stat().st_mode) == 0o666 & ~umask


def test_report_replaces_its_folder_whole(run_dir, tmp_path, capsys):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "stale.png").write_bytes(b"old image")
    fails(["report", run_dir, "--out", out], capsys, 2, "--force")
    assert tree(out) == ["stale.png"]
    assert main(["report", str(run_dir), "--out", str(out), "--force"]) == 0
    names = tree(out)
    assert "stale.png" not in names and "index.html" in names
    assert not [n for n in tree(tmp_path) if ".partial" in n or ".old-" in n]


def test_entity_name_collision_is_refused_before_logging(bundle_dir, tmp_path, capsys):
    """cam.1 and cam_1 would both be the entity cam_1: their data would merge in the recording."""
    rename = {"cam0": "cam.1", "cam1": "cam_1", "cam2": "cam2"}
    bad = tmp_path / "b"
    for p in sorted(bundle_dir.rglob("*")):
        rel = p.relative_to(bundle_dir)
        if p.suffix == ".npz":
            stem = "__".join(rename[n] for n in p.stem.split("__"))
            rel = rel.with_name(stem + ".npz")
        (bad / rel).parent.mkdir(parents=True, exist_ok=True)
        if p.is_file():
            (bad / rel).write_bytes(p.read_bytes())
    meta = json.loads((bundle_dir / "bundle.json").read_text())
    for v in meta["videos"]:
        v["name"] = rename[v["name"]]
    (bad / "bundle.json").write_text(json.dumps(meta))
    gt = json.loads((bundle_dir / "gt.json").read_text())
    (bad / "gt.json").write_text(json.dumps({"offsets_s": {rename[k]: x for k, x in gt["offsets_s"].items()}}))
    fails(sync_argv(bad, tmp_path / "out", "--rrd", tmp_path / "recs" / "r.rrd"), capsys, 2,
          "'cam.1'", "'cam_1'", "--no-rrd")
    assert tree(tmp_path / "recs") == [] and not (tmp_path / "out").exists()
    # without a recording the names do not meet: the run goes through
    assert main([str(a) for a in sync_argv(bad, tmp_path / "out", "--no-rrd")]) in (0, 2)
    assert (tmp_path / "out" / "result.json").is_file()


# ---- options --------------------------------------------------------------------------------


def test_step_s_tiny_is_refused_before_allocating(bundle_dir, tmp_path, capsys):
    t0 = time.perf_counter()
    fails(sync_argv(bundle_dir, tmp_path / "out", "--no-rrd", "--step-s", "1e-12"), capsys, 2,
          "--step-s", "candidate offsets")
    assert time.perf_counter() - t0 < 10
    assert tree(tmp_path) == []


@pytest.mark.parametrize("option,value", [
    ("--step-s", "nan"), ("--step-s", "-0.01"), ("--step-s", "0"), ("--range-s", "inf"),
    ("--range-s", "-1"), ("--min-overlap-s", "-1"), ("--min-overlap-s", "nan"),
    ("--huber-delta-s", "-0.1"), ("--huber-delta-s", "inf"), ("--max-tracks", "0"),
    ("--keyframes", "-3"), ("--max-side", "0"), ("--seed", "-1"), ("--pairs", "1.5"),
    ("--pairs", "nan"),
])
def test_bad_numeric_option_names_the_option(bundle_dir, tmp_path, capsys, option, value):
    fails(sync_argv(bundle_dir, tmp_path / "out", "--no-rrd", option, value), capsys, 2, option)
    assert tree(tmp_path) == []


@pytest.mark.parametrize("value", ["-25", "0", "nan", "inf", "abc"])
def test_bad_fps_option_is_one_line(tmp_path, capsys, value):
    fails(["sync", "v.mp4", "--out", tmp_path / "out", "--fps", value], capsys, 2, "--fps")
    assert tree(tmp_path) == []


def test_bad_config_file_value_names_the_key(bundle_dir, tmp_path, capsys):
    cfg = tmp_path / "config.json"
    cfg.write_text(json.dumps({"sync": {"landscape": {"step_s": -1}}}))
    fails(sync_argv(bundle_dir, tmp_path / "out", "--no-rrd", "--config", cfg), capsys, 2, "step")
    assert tree(tmp_path) == ["config.json"]


def test_config_json_nested_too_deeply(bundle_dir, tmp_path, capsys):
    cfg = tmp_path / "config.json"
    cfg.write_text("[" * 100_000 + "]" * 100_000)
    fails(sync_argv(bundle_dir, tmp_path / "out", "--no-rrd", "--config", cfg), capsys, 2, str(cfg))
    assert tree(tmp_path) == ["config.json"]


# ---- hostile bundles --------------------------------------------------------------------------


def _ts_with_fps(fps):
    def edit(meta):
        v = meta["videos"][1]
        v["timestamps_s"] = [i / 30.0 for i in range(v["num_frames"])]
        v["fps"] = fps
    return edit


def _set(i, key, value):
    def edit(meta):
        meta["videos"][i][key] = value
    return edit


K_BAD_ROW = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0.5, 1]])
K_NEG_F = np.array([[-500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
T_BAD_ROW = np.eye(4)
T_BAD_ROW[3] = [0, 0, 1, 1]

BUNDLE_CASES = {
    "fps negative next to timestamps": ({"meta_edit": _ts_with_fps(-25)}, "bundle.json", "'fps'"),
    "fps zero next to timestamps": ({"meta_edit": _ts_with_fps(0)}, "bundle.json", "'fps'"),
    "fps negative": ({"meta_edit": _set(0, "fps", -25)}, "bundle.json", "'fps'"),
    "num_frames 10**13": ({"meta_edit": _set(0, "num_frames", 10**13)}, "bundle.json", "num_frames"),
    "width 10**12": ({"meta_edit": _set(0, "width", 10**12)}, "bundle.json", "width"),
    "name with newline": ({"meta_edit": _set(0, "name", "cam0\nfake row +0.0000")}, "bundle.json",
                          "control character"),
    "name 300 characters": ({"meta_edit": _set(0, "name", "c" * 300)}, "bundle.json", "300 characters"),
    "name a list": ({"meta_edit": _set(0, "name", ["cam0"])}, "bundle.json", "'name'"),
    "timestamps a string": ({"meta_edit": _set(0, "timestamps_s", "0 1 2")}, "bundle.json", "timestamps_s"),
    "K last row": ({"arrays": {"cameras/cam0.npz": {"K": K_BAD_ROW}}}, "cameras/cam0.npz", "last row of K"),
    "K negative focal": ({"arrays": {"cameras/cam0.npz": {"K": K_NEG_F}}}, "cameras/cam0.npz", "focal"),
    "cam_from_world last row": ({"arrays": {"cameras/cam1.npz": {"cam_from_world": T_BAD_ROW}}},
                                "cameras/cam1.npz", "last row of cam_from_world"),
    "complex K": ({"arrays": {"cameras/cam0.npz": {"K": np.eye(3) * (500 + 1j)}}}, "cameras/cam0.npz",
                  "complex"),
    "complex xy": ({"arrays": {"tracks/cam0.npz": {"xy": np.zeros((3, 5, 2), complex)}}}, "tracks/cam0.npz",
                   "complex"),
    "string array": ({"arrays": {"tracks/cam0.npz": {"instance": np.array(["a"])}}}, "tracks/cam0.npz",
                     "instance has dtype string; need integer ids"),
}


@pytest.mark.parametrize("case", sorted(BUNDLE_CASES))
def test_hostile_bundle(case, bundle_dir, tmp_path, capsys):
    kwargs, where, what = BUNDLE_CASES[case]
    bad = edit_bundle(bundle_dir, tmp_path / "bad", **kwargs)
    line = fails(sync_argv(bad, tmp_path / "out", "--rrd", tmp_path / "recs" / "r.rrd"), capsys, 2, what)
    assert where in line
    assert "\nfake" not in line and len(line) < 600
    assert tree(tmp_path / "out") == [] and tree(tmp_path / "recs") == []


def _npy_bytes(shape, dtype) -> bytes:
    buf = io.BytesIO()  # write_array_header_2_0 writes the magic string too
    np.lib.format.write_array_header_2_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue() + b"\0" * 64


def test_npz_header_declaring_2e12_elements_is_refused_before_loading(bundle_dir, tmp_path, capsys):
    bad = edit_bundle(bundle_dir, tmp_path / "bad")
    with np.load(bad / "tracks" / "cam0.npz") as z:
        T = z["xy"].shape[1]
    with zipfile.ZipFile(bad / "tracks" / "cam0.npz", "w") as zf:
        zf.writestr("xy.npy", _npy_bytes((10**12, T, 2), "<f8"))
    fails(sync_argv(bad, tmp_path / "out", "--no-rrd"), capsys, 2, "tracks/cam0.npz", "memory budget")
    # and a header whose shape disagrees with the declared num_frames
    with zipfile.ZipFile(bad / "tracks" / "cam0.npz", "w") as zf:
        zf.writestr("xy.npy", _npy_bytes((10, T + 1, 2), "<f8"))
    fails(sync_argv(bad, tmp_path / "out", "--no-rrd"), capsys, 2, "tracks/cam0.npz", "shape")
    assert tree(tmp_path / "out") == []


def test_memory_budget_counts_decompressed_bytes(bundle_dir, tmp_path, monkeypatch, capsys):
    """A small file that decompresses to a lot (zeros) is refused from its header."""
    bad = edit_bundle(bundle_dir, tmp_path / "bad")
    with np.load(bad / "tracks" / "cam0.npz") as z:
        T = z["xy"].shape[1]
    np.savez_compressed(bad / "tracks" / "cam0.npz", xy=np.zeros((40_000, T, 2)))
    assert (bad / "tracks" / "cam0.npz").stat().st_size < 2**20
    monkeypatch.setenv("VS_INSPECT_MEMORY_BUDGET_MB", "8")
    fails(sync_argv(bad, tmp_path / "out", "--no-rrd"), capsys, 2, "tracks/cam0.npz", "VS_INSPECT_MEMORY_BUDGET_MB")


@pytest.mark.parametrize("name", ["bundle.json", "gt.json"])
def test_json_nested_100000_levels(name, bundle_dir, tmp_path, capsys):
    bad = edit_bundle(bundle_dir, tmp_path / "bad")
    (bad / name).write_text('{"a":' * 100_000 + "1" + "}" * 100_000)
    fails(sync_argv(bad, tmp_path / "out", "--no-rrd"), capsys, 2, name, "nested")
    assert tree(tmp_path / "out") == []


# ---- hostile results and ground truth ---------------------------------------------------------


def _result_with(run_dir: Path, dst: Path, edit) -> Path:
    dst.mkdir()
    data = json.loads((run_dir / "result.json").read_text())
    edit(data)
    (dst / "result.json").write_text(json.dumps(data))
    return dst


def test_result_with_a_string_offset(run_dir, bundle_dir, tmp_path, capsys):
    def edit(d):
        d["offsets_s"][next(iter(d["offsets_s"]))] = "0.5"
    bad = _result_with(run_dir, tmp_path / "bad", edit)
    fails(["eval", bad, "--gt", bundle_dir / "gt.json"], capsys, 2, "result.json", "offsets_s")
    fails(["export", bad, "--mosaic", tmp_path / "m.mp4"], capsys, 2, "result.json", "offsets_s")
    assert tree(tmp_path) == ["bad/", "bad/result.json"]


@pytest.mark.parametrize("content", ["{}", "[]", '"x"', '{"reference": "cam0", "offsets_s": []}',
                                     '{"reference": "cam0", "offsets_s": {}, "pairs": [1]}'])
def test_malformed_result_json(content, bundle_dir, tmp_path, capsys):
    (tmp_path / "result.json").write_text(content)
    fails(["eval", tmp_path, "--gt", bundle_dir / "gt.json"], capsys, 2, "result.json")
    fails(["report", tmp_path, "--out", tmp_path / "rep"], capsys, 2)
    assert tree(tmp_path) == ["result.json"]


def test_eval_gt_naming_a_folder(run_dir, tmp_path, capsys):
    fails(["eval", run_dir, "--gt", tmp_path], capsys, 2, str(tmp_path), "folder")


def test_eval_gt_nested_too_deeply(run_dir, tmp_path, capsys):
    (tmp_path / "gt.json").write_text("[" * 100_000 + "]" * 100_000)
    fails(["eval", run_dir, "--gt", tmp_path / "gt.json"], capsys, 2, "gt.json")


# ---- errors no reader check caught --------------------------------------------------------------


@pytest.mark.parametrize("exc,needle", [
    (MemoryError("Unable to allocate 2 TiB"), "out of memory"),
    (RecursionError("maximum recursion depth exceeded"), "nested too deeply"),
    (TypeError("'NoneType' object is not subscriptable"), "TypeError"),
    (KeyError("xy"), "KeyError"),
    (IsADirectoryError(21, "Is a directory", "/some/where"), "/some/where"),
    (PermissionError(13, "Permission denied", "/some/file"), "/some/file"),
])
def test_unexpected_errors_are_one_line(exc, needle, bundle_dir, tmp_path, monkeypatch, capsys):
    import vs_inspect.commands.sync as sync_cmd

    def boom(*a, **k):
        raise exc
    monkeypatch.setattr(sync_cmd, "run_pipeline", boom)
    fails(sync_argv(bundle_dir, tmp_path / "out", "--rrd", tmp_path / "recs" / "r.rrd"), capsys, 2, needle)
    assert tree(tmp_path) == []  # no .partial, no lock, and no folder made for the recording


# ---- SIGTERM takes Ctrl-C's cleanup path ------------------------------------------------------


def _run_and_terminate(script: str, tmp_path: Path, ready: str = "READY",
                       sig: int = signal.SIGTERM) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "TMPDIR": str(tmp_path / "tmp")}
    (tmp_path / "tmp").mkdir(exist_ok=True)
    # SIGINT at its default in the child: a test run started as a shell's background job ignores
    # SIGINT, the child would inherit that, and Python installs no KeyboardInterrupt handler then
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(script)], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    line = ""
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if ready in line or not line:
            break
    assert ready in line, proc.stderr.read()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


@pytest.mark.parametrize("sig,code,word", [(signal.SIGTERM, 143, "SIGTERM"),
                                           (signal.SIGINT, 130, "SIGINT")])
def test_sigterm_during_sync_removes_the_partial_recording(bundle_dir, tmp_path, sig, code, word):
    """SIGTERM takes Ctrl-C's path: the same cleanup, exit 143 (Ctrl-C: 130)."""
    script = f"""
        import numpy, sys, time
        import vs_inspect.commands.sync as s
        real = s.run_pipeline
        from vs_inspect import signals
        def slow(*a, **k):
            r = real(*a, **k)
            print("READY", flush=True)
            for _ in range(600):  # work between safe points
                time.sleep(0.1)
                signals.checkpoint()
            return r
        s.run_pipeline = slow
        from vs_inspect.cli import main
        sys.exit(main(["sync", "--bundle", {str(bundle_dir)!r}, "--out", "out", "--rrd", "recs/r.rrd",
                       "--no-progress"]))
    """
    r = _run_and_terminate(script, tmp_path, sig=sig)
    assert r.returncode == code, r.stderr
    assert r.stderr.strip().splitlines() == [f"vs-inspect sync: interrupted by {word}; nothing written "
                                             "to out, recs/r.rrd"]
    assert tree(tmp_path / "recs") == [] and not (tmp_path / "out").exists()
    assert tree(tmp_path / "tmp") == []


def test_sigterm_during_report_leaves_no_folder(run_dir, tmp_path):
    script = f"""
        import numpy, sys, time
        import vs_inspect.report.figures as f
        real = f.landscapes
        from vs_inspect import signals
        def slow(*a, **k):
            real(*a, **k)
            print("READY", flush=True)
            for _ in range(600):
                time.sleep(0.1)
                signals.checkpoint()
        f.landscapes = slow
        from vs_inspect.cli import main
        sys.exit(main(["report", {str(run_dir)!r}, "--out", "rep"]))
    """
    r = _run_and_terminate(script, tmp_path)
    assert r.returncode == 143, r.stderr
    assert "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == ["vs-inspect report: interrupted by SIGTERM; nothing written to rep"]
    assert tree(tmp_path) == ["tmp/"]  # no rep/, no .rep.partial-*


def test_sigterm_during_sfm_removes_the_scratch_folder(tmp_path):
    """pycolmap's scratch folder (and its log files) live in one folder the run removes, also on
    SIGTERM (pycolmap's glog replaces the SIGTERM handler at import: signals.import_pycolmap puts
    ours back)."""
    script = """
        import numpy, sys, time
        from vs_inspect.signals import Terminated, install
        install()  # as vs_inspect.cli.main does
        import vs_inspect.cues.cameras.sfm as c
        from vs_inspect import signals
        def slow(*a, **k):
            print("READY", flush=True)
            for _ in range(600):
                time.sleep(0.1)
                signals.checkpoint()
        c.sift_database = slow
        from vs_inspect.cues.config import CameraConfig
        img = numpy.zeros((64, 64, 3), numpy.uint8)
        frames = {"a": ([0, 1, 2], [img] * 3, [None] * 3), "b": ([0, 1, 2], [img] * 3, [None] * 3)}
        try:
            c.estimate_cameras(frames, {"a": (64, 64), "b": (64, 64)}, {"a": 3, "b": 3},
                               {"a": False, "b": False}, CameraConfig(features="sift"), None, 0)
        except Terminated:
            sys.exit(143)
    """
    r = _run_and_terminate(script, tmp_path)
    assert r.returncode == 143, r.stderr[-2000:]
    assert "Aborted" not in r.stderr and "stack trace" not in r.stderr
    assert tree(tmp_path / "tmp") == []


def test_sigterm_while_writing_a_video_removes_the_partial_mp4(tmp_path):
    """export's mosaic: the VideoWriter's hidden .partial.mp4 is removed on SIGTERM."""
    script = """
        import numpy, sys
        from vs_inspect.signals import Terminated, install
        install()
        from vs_inspect.io.video import VideoWriter
        try:
            with VideoWriter("m.mp4", 64, 48, 10.0) as vw:
                k = 0
                while True:
                    vw.write(numpy.full((48, 64, 3), k % 255, numpy.uint8))
                    k += 1
                    if k == 20:
                        print("READY", flush=True)
        except Terminated:
            sys.exit(143)
    """
    r = _run_and_terminate(script, tmp_path)
    assert r.returncode == 143, r.stderr
    assert tree(tmp_path) == ["tmp/"]


# ---- hostile recordings -------------------------------------------------------------------------


def _recording(path: Path, meta, result=None) -> Path:
    import rerun as rr

    from vs_inspect.io.recording_paths import APPLICATION_ID, META_RECORDING, META_RESULT
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=path.stem)
    rec.save(str(path))
    rec.log(META_RECORDING, rr.TextDocument(json.dumps(meta), media_type="text/plain"), static=True)
    if result is not None:
        rec.log(META_RESULT, rr.TextDocument(json.dumps(result), media_type="text/plain"), static=True)
    rec.flush()
    rec.disconnect()
    return path


@pytest.mark.parametrize("meta,result,needle", [
    (["not", "an", "object"], None, "not a vs_inspect recording"),
    ({"format": "vs-inspect-recording"}, {}, "result"),
    ({"format": "vs-inspect-recording"}, {"reference": "a", "offsets_s": {"a": "0.5"}}, "offsets_s"),
])
def test_hostile_recording(meta, result, needle, tmp_path, capsys):
    from vs_inspect.io.recording_paths import RECORDING_FORMAT
    if isinstance(meta, dict):
        meta = {**meta, "format": RECORDING_FORMAT}
    rrd = _recording(tmp_path / "r.rrd", meta, result)
    fails(["inspect", rrd], capsys, 2, "r.rrd", needle)
    fails(["report", rrd, "--out", tmp_path / "rep"], capsys, 2, "r.rrd")
    assert tree(tmp_path) == ["r.rrd"]


# ---- hostile video inputs (names come from file names) --------------------------------------


def _image_folder(folder: Path, frames: int = 3) -> Path:
    import cv2
    folder.mkdir(parents=True)
    for k in range(frames):
        cv2.imwrite(str(folder / f"{k:04d}.png"), np.full((32, 32, 3), 40 * k, np.uint8))
    return folder


@pytest.mark.parametrize("name,needle", [("cam\nfake", "control character"), ("c" * 210, "210 characters")])
def test_video_name_from_a_file_name_is_checked(name, needle, tmp_path, capsys):
    a, b = _image_folder(tmp_path / "in" / name), _image_folder(tmp_path / "in" / "other")
    fails(["sync", a, b, "--fps", "10", "--out", tmp_path / "out", "--no-rrd", "--no-progress"], capsys, 2,
          needle)
    assert not (tmp_path / "out").exists()


def test_entity_collision_of_video_files_is_refused_before_any_work(tmp_path, capsys):
    a, b = _image_folder(tmp_path / "in" / "cam.1"), _image_folder(tmp_path / "in" / "cam_1")
    t0 = time.perf_counter()
    fails(["sync", a, b, "--fps", "10", "--out", tmp_path / "out", "--rrd", tmp_path / "r.rrd",
           "--no-progress"], capsys, 2, "'cam.1'", "'cam_1'")
    assert time.perf_counter() - t0 < 5
    assert tree(tmp_path) == sorted(["in/", "in/cam.1/", "in/cam_1/"] +
                                    [f"in/{n}/{k:04d}.png" for n in ("cam.1", "cam_1") for k in range(3)])


def test_result_with_a_newline_in_a_video_name_cannot_forge_table_lines(run_dir, bundle_dir, tmp_path, capsys):
    def edit(d):
        first = next(iter(d["offsets_s"]))
        d["offsets_s"]["cam9\ncam0   +0.0000"] = d["offsets_s"].pop(first)
    bad = _result_with(run_dir, tmp_path / "bad", edit)
    fails(["eval", bad, "--gt", bundle_dir / "gt.json"], capsys, 2, "control character")
    assert tree(tmp_path) == ["bad/", "bad/result.json"]


@pytest.mark.skipif(_can_mount() is not None, reason=str(_can_mount()))
def test_report_on_a_full_file_system_leaves_nothing(run_dir, tmp_path, capsys):
    full = tmp_path / "full"
    with tmpfs(full, "64k"):
        fails(["report", run_dir, "--out", full / "rep"], capsys, 2, "no space left on device")
        assert tree(full) == []  # no rep/, no .rep.partial-*, no 0-byte PNG


def test_report_on_a_read_only_file_system(run_dir, tmp_path, capsys):
    ro = tmp_path / "ro"
    with read_only_folder(ro):
        if os.access(ro, os.W_OK) and os.geteuid() != 0:
            pytest.skip("chmod 0o555 does not stop writes here")
        line = fails(["report", run_dir, "--out", ro / "rep"], capsys, 2, str(ro))
        assert "read-only file system" in line or "Permission denied" in line
        assert tree(ro) == ["keep.txt"]
