"""Video input and output: files through PyAV (per-frame timestamps), folders of images, H.264 writer.

    video_source.py  open_video: a file or an image folder probed once into a VideoSource (its clock)
    video_frames.py  iter_frames, read_frames, downscale: frames by index
    video_writer.py  VideoWriter: H.264 MP4, atomically

Frame k of a video is the k-th frame in presentation order; its local time is
``info.timestamps_s[k]``, taken from the container's presentation timestamps (PTS) and shifted so
that frame 0 is at 0.0. Variable-frame-rate video (phones) keeps its real frame times.

Every problem a user can fix (missing file, not a video, zero frames, truncated or corrupt stream)
is raised as :class:`vs_inspect.errors.InputError` naming the file.
"""

from __future__ import annotations

# re-exported: the stages and tools import video I/O from here
from .video_frames import downscale, iter_frames, read_frames  # noqa: F401
from .video_source import (  # noqa: F401
    CONSTANT_RATE_TOLERANCE, IMAGE_SUFFIXES, VIDEO_SUFFIXES, VideoSource, open_video,
)
from .video_writer import VideoWriter  # noqa: F401
