"""A cue bundle as one zip archive in memory, so that a recording can carry the cues it was made
from (cameras, tracks, track pairs) and a report can be made from the recording alone."""

from __future__ import annotations

import io
import tempfile
import zipfile
from pathlib import Path

from ..errors import BundleError
from ..types import CueBundle
from .bundle import MEMORY_BUDGET_ENV, memory_budget_bytes, read_bundle, write_bundle


def bundle_to_zip_bytes(bundle: CueBundle) -> bytes:
    """The bundle folder (format v1, as write_bundle makes it) zipped into bytes."""
    with tempfile.TemporaryDirectory(prefix="vs-inspect-bundle-") as tmp:
        folder = write_bundle(bundle, Path(tmp) / "bundle")
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:  # the .npz files are compressed already
            for p in sorted(folder.rglob("*")):
                if p.is_file():
                    zf.write(p, p.relative_to(folder).as_posix())
        return buf.getvalue()


def bundle_from_zip_bytes(data: bytes, where: str = "<recording>") -> CueBundle:
    """Read back what bundle_to_zip_bytes wrote (validated like a bundle folder)."""
    try:
        zf = zipfile.ZipFile(io.BytesIO(bytes(data)))
    except zipfile.BadZipFile as exc:
        raise BundleError(where, f"embedded cue bundle is not a zip archive ({exc})") from None
    with zf, tempfile.TemporaryDirectory(prefix="vs-inspect-bundle-") as tmp:
        for name in zf.namelist():
            if name.startswith("/") or ".." in Path(name).parts:
                raise BundleError(where, f"embedded cue bundle has an unsafe path {name!r}")
        size = sum(i.file_size for i in zf.infolist())  # declared sizes: checked before extracting
        if size > memory_budget_bytes():
            raise BundleError(where, f"embedded cue bundle unpacks to {size / 2**20:.1f} MB, more than "
                                     f"the memory budget ({MEMORY_BUDGET_ENV})")
        zf.extractall(tmp)
        return read_bundle(tmp)
