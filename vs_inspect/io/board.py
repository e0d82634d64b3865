"""Read a ChArUco board description: caliscope's charuco.toml, or the same keys in JSON.

caliscope keys: columns, rows (squares), dictionary, aruco_scale (marker side / square side),
inverted, square_size_override_cm, or else board_width / board_height with units (the square is
the largest that fits the sheet).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError

@dataclass(frozen=True)
class BoardSpec:
    columns: int  # squares along x
    rows: int  # squares along y
    square_m: float  # side of a square, metres
    marker_m: float  # side of an ArUco marker, metres
    dictionary: str  # OpenCV name, e.g. "DICT_4X4_1000"
    inverted: bool = False  # printed white-on-black: detect on the inverted image

    def __post_init__(self) -> None:
        if self.columns < 2 or self.rows < 2:
            raise ValueError(f"a ChArUco board needs at least 2x2 squares, got {self.columns}x{self.rows}")
        if not 0 < self.marker_m < self.square_m:
            raise ValueError(f"marker side {self.marker_m} m must be positive and below the square "
                             f"side {self.square_m} m")
        if not hasattr(cv2.aruco, self.dictionary):
            raise ValueError(f"unknown ArUco dictionary {self.dictionary!r} (e.g. DICT_4X4_1000)")

    def board(self):
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.columns, self.rows), self.square_m, self.marker_m, d)

    def corners_m(self) -> np.ndarray:
        """(C,3) inner corners in the board frame, metres, indexed by corner id."""
        return np.asarray(self.board().getChessboardCorners(), dtype=np.float64)



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
