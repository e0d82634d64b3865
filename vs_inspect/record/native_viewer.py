"""The native rerun viewer (from rerun-sdk) run in software rendering (Mesa lavapipe through
Vulkan): under Xvfb when it is on PATH, else in the viewer's own headless mode, with a
rerun.experimental.ViewerClient connected to it; and its screenshots as images."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

WINDOW = (1920, 1080)  # logical points


def rerun_executable() -> Path | None:
    """The viewer that comes with the installed rerun-sdk (beside this Python), else on PATH."""
    here = Path(sys.executable).parent / "rerun"
    if here.is_file():
        return here
    found = shutil.which("rerun")
    return Path(found) if found else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _software_env(base: dict[str, str]) -> dict[str, str]:
    """Software rendering: Mesa's lavapipe Vulkan driver when installed, llvmpipe GL otherwise."""
    env = dict(base)
    icd = Path("/usr/share/vulkan/icd.d/lvp_icd.x86_64.json")
    if icd.is_file():
        env.setdefault("VK_ICD_FILENAMES", str(icd))
        env.setdefault("WGPU_BACKEND", "vulkan")
    else:
        env.setdefault("WGPU_BACKEND", "gl")
    env.setdefault("LIBGL_ALWAYS_SOFTWARE", "1")
    return env


@contextlib.contextmanager
def viewer(mode: str = "auto", size: tuple[int, int] = WINDOW, log_path: Path | None = None):
    """A running native viewer and a ViewerClient connected to it; both are stopped on exit.

    mode: "xvfb" (a virtual X display), "headless" (the viewer's offscreen mode) or "auto" (xvfb
    when Xvfb is on PATH). RuntimeError with the viewer's output when it does not come up.
    """
    from rerun.experimental import ViewerClient

    exe = rerun_executable()
    if exe is None:
        raise RuntimeError("no rerun viewer executable (install rerun-sdk)")
    if mode == "auto":
        mode = "xvfb" if shutil.which("Xvfb") else "headless"
    env = _software_env(os.environ)
    tmp = tempfile.TemporaryDirectory(prefix="vs-inspect-viewer-")
    env.setdefault("XDG_RUNTIME_DIR", tmp.name)
    env.setdefault("XDG_CONFIG_HOME", str(Path(tmp.name) / "config"))
    env.setdefault("XDG_DATA_HOME", str(Path(tmp.name) / "data"))
    procs: list[subprocess.Popen] = []
    log = open(log_path or Path(tmp.name) / "viewer.log", "w")
    try:
        if mode == "xvfb":
            xvfb = shutil.which("Xvfb")
            if xvfb is None:
                raise RuntimeError("Xvfb is not on PATH (apt-get install xvfb), or use mode='headless'")
            # -displayfd: Xvfb picks a free display number and writes it to the pipe
            r, w = os.pipe()
            procs.append(subprocess.Popen([xvfb, "-displayfd", str(w), "-screen", "0",
                                           f"{size[0]}x{size[1]}x24", "-nolisten", "tcp"],
                                          pass_fds=(w,), stdout=log, stderr=log, start_new_session=True))
            os.close(w)
            with os.fdopen(r) as f:
                display = f.readline().strip()
            if not display:
                raise RuntimeError("Xvfb did not start")
            env["DISPLAY"] = f":{display}"
            env.pop("WAYLAND_DISPLAY", None)
        port = _free_port()
        cmd = [str(exe), "--port", str(port), "--hide-welcome-screen", "--window-size",
               f"{size[0]}x{size[1]}", "--memory-limit", "2GB"]
        if mode == "headless":
            cmd.append("--headless")
        procs.append(subprocess.Popen(cmd, env=env, stdout=log, stderr=log, start_new_session=True))
        deadline = time.monotonic() + 30
        while True:
            try:
                client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
                client.get_state()
                break
            except Exception:  # noqa: BLE001 - not listening yet
                if procs[-1].poll() is not None or time.monotonic() > deadline:
                    log.flush()
                    text = Path(log.name).read_text(errors="replace")[-2000:]
                    raise RuntimeError(f"the rerun viewer did not come up ({mode}):\n{text}") from None
                time.sleep(0.3)
        yield client
    finally:
        for p in reversed(procs):  # only the processes started here, each by its own group
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, 15)
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, 9)
                p.wait(timeout=5)
        log.close()
        tmp.cleanup()


def _open(client, path: Path, timeout_s: float = 30.0) -> str:
    """Open an .rrd, wait until it is loaded; its store id."""
    from .viewer import wait_loaded
    return wait_loaded(client, path, timeout_s)


def _png(data: bytes) -> np.ndarray:
    import cv2
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise RuntimeError("the viewer returned no image")
    return img


def _paint(client, settle_s: float, min_rounds: int = 2, max_rounds: int = 6) -> None:
    """Let the viewer paint until two frames in a row look the same, after at least min_rounds
    (images and videos are decoded in the background and appear some frames later; the viewer
    paints only when asked), at most max_rounds times. A screenshot the viewer does not deliver in
    time (a new layout in software rendering on a busy machine) counts as a round."""
    prev = None
    for i in range(max_rounds):
        time.sleep(settle_s / 2)
        try:
            img = _png(client.take_screenshot(max_size=480))
        except TimeoutError:
            prev = None
            continue
        if i + 1 >= min_rounds and prev is not None and img.shape == prev.shape and \
                np.abs(img.astype(np.int16) - prev.astype(np.int16)).max() <= 8:
            return
        prev = img
