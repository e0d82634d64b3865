"""Read a ChArUco board description: caliscope's charuco.toml, or the same keys in JSON.

caliscope keys: columns, rows (squares), dictionary, aruco_scale (marker side / square side),
inverted, square_size_override_cm, or else board_width / board_height with units (the square is
the largest that fits the sheet).
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from ..cues.board import BoardSpec
from ..errors import InputError

_UNIT_M = {"inch": 0.0254, "in": 0.0254, "cm": 0.01, "mm": 0.001, "m": 1.0}


def load_board(path) -> BoardSpec:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: board file not found")
    try:
        text = path.read_text()
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise InputError(f"{path}: not a readable board description ({exc})") from None
    missing = [k for k in ("columns", "rows", "dictionary") if k not in data]
    if missing:
        raise InputError(f"{path}: board description lacks {missing} (has {sorted(data)})")
    try:
        columns, rows = int(data["columns"]), int(data["rows"])
        if data.get("square_size_override_cm"):
            square = 0.01 * float(data["square_size_override_cm"])
        else:
            unit = str(data.get("units", "m")).lower()
            if unit not in _UNIT_M:
                raise InputError(f"{path}: unknown units {unit!r}; use one of {sorted(_UNIT_M)}")
            square = _UNIT_M[unit] * min(float(data["board_width"]) / columns,
                                         float(data["board_height"]) / rows)
        marker = square * float(data.get("aruco_scale", 0.75))
        return BoardSpec(columns, rows, square, marker, str(data["dictionary"]),
                         bool(data.get("inverted", False)))
    except KeyError as exc:
        raise InputError(f"{path}: give square_size_override_cm or board_width, board_height "
                         f"and units (missing {exc})") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"{path}: {exc}") from None
