"""Files other tools read, from a synchronized run: per-video offsets (CSV, JSON) and each video
trimmed to the common time span (H.264 MP4 through PyAV, frame-accurate at its own rate; a
timestamps file beside each video whose rate varies).

Sign: offset_s is the moment the video's first frame was taken, in seconds on the reference
video's clock; positive means the video started after the reference. offset_frames is the same
in frames of that video. first_frame is the first frame of the video inside the common span: drop
frames before it (and after last_frame) and all videos show the same moments.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ..result_types import CommonSpan
from .atomic import write_json_atomic, write_text_atomic

SIGN = ("offset_s: when the video's first frame was taken, in seconds on {ref}'s clock "
        "(positive: the video started after {ref}); offset_frames: the same in frames of that "
        "video; first_frame..last_frame: its frames inside the common span (drop the others and "
        "every video starts at the same moment)")
COLUMNS = ("video", "offset_s", "offset_frames", "fps", "first_frame", "last_frame", "frames",
           "first_frame_time_s")


def offsets_rows(span: CommonSpan, names: list[str], offsets_s: dict) -> list[dict]:
    rows = []
    for n in names:
        s = span.videos.get(n)
        if s is None:
            rows.append({"video": n, "offset_s": None, "offset_frames": None, "fps": None,
                         "first_frame": None, "last_frame": None, "frames": None,
                         "first_frame_time_s": None})
            continue
        rows.append({"video": n, "offset_s": round(s.offset_s, 6),
                     "offset_frames": round(s.offset_frames, 4),
                     "fps": round(1.0 / s.frame_interval_s, 6) if math.isfinite(s.frame_interval_s) else None,
                     "first_frame": s.first_frame, "last_frame": s.last_frame, "frames": s.num_frames,
                     "first_frame_time_s": round(s.first_time_s, 6)})
    return rows


def write_offsets(path: Path, span: CommonSpan, names: list[str], offsets_s: dict) -> Path:
    """FILE.csv (a '#' header line with the sign, then one row per video; empty cells for a
    video without offset) or FILE.json."""
    rows = offsets_rows(span, names, offsets_s)
    sign = SIGN.format(ref=span.reference)
    if path.suffix.lower() == ".json":
        return write_json_atomic({
            "reference": span.reference, "sign": sign,
            "common_span_s": [round(span.start_s, 6), round(span.end_s, 6)],
            "videos": {r["video"]: {k: v for k, v in r.items() if k != "video"} for r in rows},
            "unsynchronized": dict(span.skipped)}, path)
    buf = io.StringIO()
    buf.write(f"# reference {span.reference}; {sign}\n")
    w = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    return write_text_atomic(buf.getvalue(), path)


def write_trimmed(folder: Path, span: CommonSpan, sources: dict, crf: int = 17,
                  progress: bool = True) -> list[Path]:
    """FOLDER/<name>.mp4 for every synchronized video: frames first_frame..last_frame, each at
    its own time from the first (constant-rate videos keep their rate); FOLDER/<name>.timestamps.txt
    (one local time per line, s) for a video without a constant rate; FOLDER/trim.json."""
    from .atomic import atomic_dir
    with atomic_dir(folder, overwrite=True) as tmp:  # all videos, or none
        names = _write_trimmed_into(tmp, span, sources, crf, progress)
    return [folder / n for n in names]


def _write_trimmed_into(folder: Path, span: CommonSpan, sources: dict, crf: int, progress: bool) -> list[str]:
    from tqdm import tqdm
    from .video import VideoWriter, iter_frames
    written = []
    for name, s in span.videos.items():
        src = sources[name]
        info = src.info
        ts = info.timestamps_s
        fps = info.fps or (1.0 / s.frame_interval_s)
        out = folder / f"{name}.mp4"
        bar = tqdm(total=s.num_frames, desc=f"trim {name}", unit="frame", disable=not progress,
                   leave=False)
        with VideoWriter(out, info.width, info.height, fps, crf=crf) as w:
            for k, img in iter_frames(src):
                if k < s.first_frame:
                    continue
                if k > s.last_frame:
                    break
                w.write(img, None if info.fps else float(ts[k] - ts[s.first_frame]))
                bar.update(1)
        bar.close()
        written.append(out)
        if not info.fps:
            stamps = "\n".join(f"{ts[k] - ts[s.first_frame]:.6f}" for k in range(s.first_frame, s.last_frame + 1))
            written.append(write_text_atomic(stamps + "\n", folder / f"{name}.timestamps.txt"))
    written.append(write_json_atomic({
        "reference": span.reference, "sign": SIGN.format(ref=span.reference),
        "common_span_s": [round(span.start_s, 6), round(span.end_s, 6)],
        "videos": {n: {"file": f"{n}.mp4", "first_frame": s.first_frame, "last_frame": s.last_frame,
                       "first_frame_time_s": round(s.first_time_s, 6),
                       "timestamps": None if sources[n].info.fps else f"{n}.timestamps.txt"}
                   for n, s in span.videos.items()},
        "unsynchronized": dict(span.skipped)}, folder / "trim.json"))
    return [p.name for p in written]
