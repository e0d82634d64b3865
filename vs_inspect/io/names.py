"""What a video name may be: it names files and recording entities and is printed in tables."""

from __future__ import annotations

MAX_NAME_CHARS = 200      # a video name is a file name and an entity path: keep it printable


def check_video_name(name: object) -> str | None:
    """Why `name` cannot be a video name (None when it can): it names files and recording entities
    and is printed in tables, so it is a short, printable, file-safe string."""
    if not isinstance(name, str) or not name:
        return "must be a non-empty string"
    if len(name) > MAX_NAME_CHARS:
        return f"is {len(name)} characters long (at most {MAX_NAME_CHARS})"
    if any(not c.isprintable() for c in name):
        return "has a newline or another control character"
    if "/" in name or name.startswith("."):
        return "must be file-safe (no '/', not starting with '.')"
    return None
