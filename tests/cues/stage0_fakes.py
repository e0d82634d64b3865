"""What the Stage 0 tests of the joint vote and of the camera choice share: a pinhole K and a sink
that keeps the stage events' messages."""

from __future__ import annotations

import numpy as np

from vs_inspect.record.sink import NullSink

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])


class Events(NullSink):
    def __init__(self):
        self.options = None
        self.messages: list[str] = []

    def stage_event(self, stage, message, **numbers):
        self.messages.append(message)
