"""Each video's own cues, found before any other video is looked at: decoding (extract), moving
regions and whether the camera moves (motion), point tracks inside the moving regions (tracking)."""
