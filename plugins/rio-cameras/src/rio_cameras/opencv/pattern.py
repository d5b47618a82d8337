"""`url = "test:pattern"`: a moving synthetic picture for demos and tests without a camera or a file.

`PatternCapture` answers the part of `cv2.VideoCapture` the stream driver uses (`isOpened`, `read`, `get`,
`set`, `release`, `getBackendName`) and hands out BGR frames, so everything after the capture (pacing,
BGR->RGB, resizing, timestamps, the grab thread) is the same code that serves a real stream. No codec
and no device run: it shows the pipeline works, not that a camera or a decoder does.

The picture: eight vertical colour bars (red, green, blue, yellow, cyan, magenta, white, black from the
left, in RGB) with a white square sweeping across the middle, one step per frame, and the frame count in
binary as black/white cells along the bottom row.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: The bars, in RGB, left to right.
BARS_RGB = ((255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (0, 255, 255), (255, 0, 255), (255, 255, 255),
            (0, 0, 0))


class PatternCapture:
    def __init__(self, width: int, height: int, fps: float):
        self.width, self.height, self.fps = int(width), int(height), float(fps)
        self.count = 0
        self.opened = True
        cols = (np.arange(self.width) * len(BARS_RGB)) // self.width
        rgb = np.asarray(BARS_RGB, np.uint8)[cols]  # (w, 3)
        self.background = np.ascontiguousarray(np.broadcast_to(rgb[None, :, ::-1], (self.height, self.width, 3)))

    def isOpened(self) -> bool:  # noqa: N802 - cv2.VideoCapture's spelling
        return self.opened

    def getBackendName(self) -> str:  # noqa: N802
        return "rio test pattern"

    def read(self) -> tuple[bool, np.ndarray | None]:
        if not self.opened:
            return False, None
        self.count += 1
        img = self.background.copy()
        side = max(self.height // 4, 1)
        x0 = (self.count * max(self.width // 64, 1)) % max(self.width - side, 1)
        y0 = (self.height - side) // 2
        img[y0:y0 + side, x0:x0 + side] = 255
        cell = max(self.width // 32, 1)
        row = img[self.height - cell:]
        for bit in range(min(32, self.width // cell)):
            row[:, bit * cell:(bit + 1) * cell] = 255 if (self.count >> bit) & 1 else 0
        return True, img

    def get(self, prop: int) -> float:
        import cv2

        return {cv2.CAP_PROP_FRAME_WIDTH: float(self.width), cv2.CAP_PROP_FRAME_HEIGHT: float(self.height),
                cv2.CAP_PROP_FPS: self.fps, cv2.CAP_PROP_POS_FRAMES: float(self.count)}.get(prop, 0.0)

    def set(self, prop: int, value: Any) -> bool:
        return False

    def release(self) -> None:
        self.opened = False
