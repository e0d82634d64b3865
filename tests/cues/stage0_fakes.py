"""What the Stage 0 tests of the joint vote and of the camera choice share: a pinhole K."""

from __future__ import annotations

import numpy as np

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
